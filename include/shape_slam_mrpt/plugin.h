// The MRPT plugin: libshape_slam_mrpt.so registers its classes with MRPT when it is loaded, by
// LD_PRELOAD (icp-slam, pf-localization, rbpf-slam, observations2map), by an application's
// plugin option (rawlog-edit --plugins, RawLogViewer -l) or by linking it:
//  * RTTI (mrpt::rtti::registerClass): shape_slam::CPolylineMap, shape_slam::CPolylinePointsMap,
//    so that archives holding them can be read and CMultiMetricMap can copy them;
//  * the map registry (ini creation): "shape_slam::CPolylineMap" / "polylineMap" and
//    "shape_slam::CPolylinePointsMap" / "polylinePointsMap".
#pragma once

namespace shape_slam {

/// Registers the classes with MRPT's RTTI (idempotent; the library already did it when loaded).
/// A program linking the library should call it once: a linker using --as-needed drops a
/// library none of whose symbols is referenced, and its registration with it.
void RegisterMrptClasses();

}  // namespace shape_slam

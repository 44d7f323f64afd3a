// Self-registration of the plugin's classes with MRPT when the library is loaded.
#include "shape_slam_mrpt/plugin.h"

#include <mrpt/core/initializer.h>
#include <mrpt/rtti/CObject.h>

#include "shape_slam_mrpt/polyline_map.h"
#include "shape_slam_mrpt/polyline_points_map.h"

namespace shape_slam {

// The map registry (ini creation) is filled by MAP_DEFINITION_REGISTER in the classes' sources;
// this is the RTTI part, which IMPLEMENTS_SERIALIZABLE does not do.
void RegisterMrptClasses() {
  mrpt::rtti::registerClass(CLASS_ID(CPolylineMap));
  mrpt::rtti::registerClass(CLASS_ID(CPolylinePointsMap));
}

}  // namespace shape_slam

MRPT_INITIALIZER(shape_slam_register_mrpt_classes) { shape_slam::RegisterMrptClasses(); }

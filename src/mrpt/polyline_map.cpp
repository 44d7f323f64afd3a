// CPolylineMap: construction, options, state, serialization, ini definition.
#include "shape_slam_mrpt/polyline_map.h"

#include <mrpt/serialization/CArchive.h>

#include <algorithm>
#include <atomic>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "option_fields.h"
#include "shape_slam_io/map_file.h"
#include "polyline_geometry.h"

IMPLEMENTS_SERIALIZABLE(CPolylineMap, mrpt::maps::CMetricMap, shape_slam)

MAP_DEFINITION_REGISTER("shape_slam::CPolylineMap,polylineMap", shape_slam::CPolylineMap)

namespace shape_slam {
namespace {

// Guards against absurd counts in corrupt archives (the vectors are not reserved from them).
constexpr std::uint64_t kMaxSerializedCount = 100000000;

PolylineMap Rebuilt(const PolylineMap& map, double cell_size_m) {
  PolylineMap rebuilt(cell_size_m);
  for (const PolylineId id : map.Ids()) rebuilt.Add(map.Get(id));
  return rebuilt;
}

void WriteOptions(mrpt::serialization::CArchive& out, const PolylineMapOptions& options) {
  PolylineMapOptions copy = options;
  const std::vector<OptionField> fields = OptionFields(copy);
  out.WriteAs<std::uint32_t>(fields.size());
  for (const OptionField& field : fields) {
    out << static_cast<std::uint8_t>(field.section) << std::string(field.key) << FieldValue(field);
  }
}

PolylineMapOptions ReadOptions(mrpt::serialization::CArchive& in) {
  PolylineMapOptions options;
  std::vector<OptionField> fields = OptionFields(options);
  const auto count = in.ReadAs<std::uint32_t>();
  if (count > kMaxSerializedCount) throw std::runtime_error("corrupt option count");
  for (std::uint32_t i = 0; i < count; ++i) {
    std::uint8_t section = 0;
    std::string key;
    double value = 0.0;
    in >> section >> key >> value;
    const auto field = std::find_if(fields.begin(), fields.end(), [&](const OptionField& f) {
      return static_cast<std::uint8_t>(f.section) == section && key == f.key;
    });
    if (field == fields.end()) {
      throw std::runtime_error("unknown option '" + key + "' (written by a newer version?)");
    }
    SetFieldValue(*field, value);
  }
  options.Validate();
  return options;
}

void WritePolylines(mrpt::serialization::CArchive& out, const PolylineMap& map) {
  out.WriteAs<std::uint64_t>(map.NumPolylines());
  for (const PolylineId id : map.Ids()) {
    const MapPolyline& p = map.Get(id);
    out.WriteAs<std::uint64_t>(p.points.size());
    for (std::size_t i = 0; i < p.points.size(); ++i) {
      out << p.points[i].x() << p.points[i].y() << p.support[i];
    }
    out.WriteAs<std::int32_t>(p.observations);
    out.WriteAs<std::int32_t>(p.contradictions);
  }
}

PolylineMap ReadPolylines(mrpt::serialization::CArchive& in, double cell_size_m) {
  PolylineMap map(cell_size_m);
  const auto count = in.ReadAs<std::uint64_t>();
  if (count > kMaxSerializedCount) throw std::runtime_error("corrupt polyline count");
  for (std::uint64_t k = 0; k < count; ++k) {
    MapPolyline p;
    const auto n = in.ReadAs<std::uint64_t>();
    if (n > kMaxSerializedCount) throw std::runtime_error("corrupt vertex count");
    for (std::uint64_t i = 0; i < n; ++i) {
      double x = 0.0, y = 0.0, support = 0.0;
      in >> x >> y >> support;
      p.points.emplace_back(x, y);
      p.support.push_back(support);
    }
    p.observations = in.ReadAs<std::int32_t>();
    p.contradictions = in.ReadAs<std::int32_t>();
    map.Add(std::move(p));  // validates the coordinates
  }
  return map;
}

}  // namespace

CPolylineMap::CPolylineMap(const PolylineMapOptions& options)
    : options_(options), map_(options.creation.index_cell_size_m) {
  options_.Validate();
}

void CPolylineMap::SetMap(const PolylineMap& map) {
  map_ = Rebuilt(map, options_.creation.index_cell_size_m);
  last_update_ = {};
  InvalidateGeometry();
}

void CPolylineMap::SetOptions(const PolylineMapOptions& options) {
  options.Validate();
  const bool new_index = options.creation.index_cell_size_m != options_.creation.index_cell_size_m;
  options_ = options;
  if (new_index) map_ = Rebuilt(map_, options_.creation.index_cell_size_m);
  InvalidateGeometry();
}

const PolylineGeometry& CPolylineMap::Geometry() const {
  std::shared_ptr<const PolylineGeometry> geometry = std::atomic_load(&geometry_);
  if (!geometry) {
    // Concurrent readers may build it twice; the first one stored wins and stays.
    auto built = std::make_shared<const PolylineGeometry>(map_, options_.creation.sample_spacing_m,
                                                          options_.creation.index_cell_size_m);
    if (std::atomic_compare_exchange_strong(&geometry_, &geometry, built)) geometry = built;
  }
  return *geometry;  // geometry_ keeps it alive until the next change of the map
}

void CPolylineMap::InvalidateGeometry() {
  std::atomic_store(&geometry_, std::shared_ptr<const PolylineGeometry>());
}

const std::vector<Point2>& CPolylineMap::Samples() const { return Geometry().Samples(); }

double CPolylineMap::DistanceToPolylines(const Point2& p_map, double max_distance_m) const {
  const auto nearest = Geometry().NearestWithin(p_map, max_distance_m);
  return nearest ? std::sqrt(nearest->squared_distance) : std::numeric_limits<double>::infinity();
}

bool CPolylineMap::isEmpty() const { return map_.Empty(); }

void CPolylineMap::internal_clear() {
  map_.Clear();
  last_update_ = {};
  InvalidateGeometry();
}

std::string CPolylineMap::asString() const {
  std::ostringstream s;
  s << "shape_slam::CPolylineMap: " << map_.NumPolylines() << " polylines, " << map_.NumVertices()
    << " vertices";
  if (!map_.Empty()) {
    Point2 lo = Point2::Constant(std::numeric_limits<double>::infinity());
    Point2 hi = -lo;
    for (const Polyline& p : Geometry().Polylines()) {
      for (const Point2& v : p) {
        lo = lo.cwiseMin(v);
        hi = hi.cwiseMax(v);
      }
    }
    s << ", x in [" << lo.x() << ", " << hi.x() << "] m, y in [" << lo.y() << ", " << hi.y()
      << "] m";
  }
  return s.str();
}

// Version 0: generic map params, options as (section, key, value) triples, polylines (vertices
// with support, observations, contradictions). Ids are not stored: they are renumbered in order.
std::uint8_t CPolylineMap::serializeGetVersion() const { return 0; }

void CPolylineMap::serializeTo(mrpt::serialization::CArchive& out) const {
  out << genericMapParams;
  WriteOptions(out, options_);
  WritePolylines(out, map_);
}

void CPolylineMap::serializeFrom(mrpt::serialization::CArchive& in, std::uint8_t version) {
  switch (version) {
    case 0: {
      in >> genericMapParams;
      PolylineMapOptions options;
      PolylineMap map;
      try {
        options = ReadOptions(in);
        map = ReadPolylines(in, options.creation.index_cell_size_m);
      } catch (const std::exception& e) {
        throw std::runtime_error(std::string("shape_slam::CPolylineMap: cannot read archive: ") +
                                 e.what());
      }
      options_ = options;
      map_ = std::move(map);
      last_update_ = {};
      InvalidateGeometry();
      break;
    }
    default:
      MRPT_THROW_UNKNOWN_SERIALIZATION_VERSION(version);
  }
}

// ---- ini definition ----

CPolylineMap::TMapDefinition::TMapDefinition() = default;

void CPolylineMap::TMapDefinition::loadFromConfigFile_map_specific(
    const mrpt::config::CConfigFileBase& source, const std::string& sectionNamePrefix) {
  options = LoadPolylineMapOptions(source, sectionNamePrefix, options);
  map_file = LoadMapFileOption(source, sectionNamePrefix);
}

void CPolylineMap::TMapDefinition::dumpToTextStream_map_specific(std::ostream& out) const {
  DumpPolylineMapOptions(options, "<prefix>", out);
  if (!map_file.empty()) out << "map_file (creation section) = " << map_file << "\n";
}

mrpt::maps::CMetricMap* CPolylineMap::internal_CreateFromMapDefinition(
    const mrpt::maps::TMetricMapInitializer& def) {
  const auto& definition = dynamic_cast<const CPolylineMap::TMapDefinition&>(def);
  auto map = std::make_unique<CPolylineMap>(definition.options);
  if (!definition.map_file.empty()) map->SetMap(io::LoadMapFile(definition.map_file));
  return map.release();
}

}  // namespace shape_slam

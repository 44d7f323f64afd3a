// CARMEN text logs: a survey pass (PARAMs, FLASER max range, integrity), then a streaming pass.
#include "shape_slam_io/carmen_reader.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>
#include <string_view>
#include <vector>

#include "log_reader_internal.h"

namespace shape_slam::io {
namespace {

constexpr std::size_t kMaxReadings = 100000;      // more is not a laser scan but garbage
constexpr std::size_t kReadChunkBytes = 1 << 18;  // bytes read from zlib at a time
constexpr std::size_t kMaxLineBytes = 1 << 24;    // 16 MiB: far above any real record
constexpr double kNoReturnBand_m = 0.005;         // "within 0.005 m or 0.5 % of the largest reading"
constexpr double kNoReturnBandFraction = 0.005;
constexpr double kNoReturnStep_m = 0.05;          // no-return values are this close to each other
constexpr double kMinNoReturnValue_m = 20.0;      // smaller maxima are real readings
constexpr double kMinNoReturnFraction = 0.001;    // 0.1 % of all readings
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// A malformed record; what() says what is wrong (the caller adds file:line).
class RecordError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// ---------------------------------------------------------------------------------------------
// Lines and fields.

/// The lines of a text file (plain or gzip), numbered from 1, without end-of-line characters.
class LineReader {
 public:
  explicit LineReader(const std::string& path)
      : path_(path), file_(path), buffer_(kReadChunkBytes, '\0') {}

  /// The next line (valid until the next call), or nullopt at the end. Throws LogError.
  std::optional<std::string_view> Next();
  std::size_t line_number() const { return line_number_; }

 private:
  void Refill();

  std::string path_;
  internal::GzFile file_;
  std::string buffer_;
  std::size_t begin_ = 0;  // first byte not yet returned
  std::size_t end_ = 0;    // end of the bytes read
  bool eof_ = false;
  std::size_t line_number_ = 0;
};

std::optional<std::string_view> LineReader::Next() {
  for (;;) {
    const char* start = buffer_.data() + begin_;
    const auto* newline = static_cast<const char*>(std::memchr(start, '\n', end_ - begin_));
    if (newline != nullptr || (eof_ && begin_ < end_)) {
      const char* stop = newline != nullptr ? newline : buffer_.data() + end_;
      begin_ = static_cast<std::size_t>(stop - buffer_.data()) + (newline != nullptr ? 1 : 0);
      ++line_number_;
      std::string_view line(start, static_cast<std::size_t>(stop - start));
      if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
      return line;
    }
    if (eof_) return std::nullopt;
    Refill();
  }
}

// Moves the unfinished line to the front of the buffer (growing it when the line fills it) and
// appends the next bytes of the file.
void LineReader::Refill() {
  const std::string where = path_ + ":" + std::to_string(line_number_ + 1);
  std::memmove(buffer_.data(), buffer_.data() + begin_, end_ - begin_);
  end_ -= begin_;
  begin_ = 0;
  if (end_ == buffer_.size()) {
    if (buffer_.size() >= kMaxLineBytes) {
      throw LogError(where + ": line longer than 16 MiB: not a CARMEN log");
    }
    buffer_.resize(2 * buffer_.size());
  }
  try {
    const std::size_t n = file_.Read(buffer_.data() + end_, buffer_.size() - end_);
    end_ += n;
    eof_ = n == 0;
  } catch (const internal::ZlibError& e) {
    throw LogError(where + ": " + e.what());
  }
}

std::vector<std::string_view> Tokenize(std::string_view line) {
  constexpr std::string_view kSpace = " \t\r\f\v";
  std::vector<std::string_view> tokens;
  std::size_t begin = line.find_first_not_of(kSpace);
  while (begin != std::string_view::npos) {
    const std::size_t end = std::min(line.find_first_of(kSpace, begin), line.size());
    tokens.push_back(line.substr(begin, end - begin));
    begin = line.find_first_not_of(kSpace, end);
  }
  return tokens;
}

/// A number in a CARMEN field, independent of the C locale ("nan", "inf" accepted). Values
/// beyond the range of double become +-inf (or 0 below it), as with strtod.
std::optional<double> ParseNumber(std::string_view token) {
  if (token.size() > 1 && token[0] == '+' && token[1] != '-') token.remove_prefix(1);
  double value = 0.0;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  if (end != token.data() + token.size()) return std::nullopt;
  if (ec == std::errc::result_out_of_range) return std::strtod(std::string(token).c_str(), nullptr);
  if (ec != std::errc()) return std::nullopt;
  return value;
}

/// Reads the fields of one record in order; every failure is a RecordError.
class Fields {
 public:
  explicit Fields(const std::vector<std::string_view>& tokens) : tokens_(tokens) {}

  std::size_t size() const { return tokens_.size(); }
  std::size_t remaining() const { return tokens_.size() - next_; }
  /// The next field; a record that ends early is a RecordError (a recorder that died mid-line).
  std::string_view Text() {
    if (next_ >= tokens_.size()) {
      throw RecordError("the record ends after " + std::to_string(tokens_.size()) +
                        " fields, more were expected");
    }
    return tokens_[next_++];
  }

  double Number(const char* what) {
    const std::string_view token = Text();
    const std::optional<double> value = ParseNumber(token);
    if (!value) {
      throw RecordError(std::string(what) + " (field " + std::to_string(next_) +
                        ") is not a number: '" + std::string(token) + "'");
    }
    return *value;
  }

  double FiniteNumber(const char* what) {
    const double value = Number(what);
    if (!std::isfinite(value)) {
      throw RecordError(std::string(what) + " (field " + std::to_string(next_) +
                        ") is not finite: " + internal::FormatNumber(value));
    }
    return value;
  }

  std::size_t Count(const char* what, std::size_t min_count) {
    const std::string_view token = Text();
    std::size_t value = 0;
    const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
    if (ec != std::errc() || end != token.data() + token.size()) {
      throw RecordError(std::string(what) + " (field " + std::to_string(next_) +
                        ") is not a count: '" + std::string(token) + "'");
    }
    if (value < min_count || value > kMaxReadings) {
      throw RecordError(std::string(what) + " " + std::to_string(value) + " is out of range [" +
                        std::to_string(min_count) + ", " + std::to_string(kMaxReadings) + "]");
    }
    return value;
  }

  Pose2 FinitePose(const char* what) {
    const std::string name(what);
    const double x = FiniteNumber((name + " x").c_str());
    const double y = FiniteNumber((name + " y").c_str());
    const double theta = FiniteNumber((name + " theta").c_str());
    return {x, y, NormalizeAngle(theta)};
  }

 private:
  const std::vector<std::string_view>& tokens_;
  std::size_t next_ = 0;
};

// ---------------------------------------------------------------------------------------------
// Records.

enum class RecordKind { kOther, kParam, kFlaser, kRobotLaser1 };

RecordKind KindOf(std::string_view tag) {
  if (tag == "FLASER") return RecordKind::kFlaser;
  if (tag == "ROBOTLASER1") return RecordKind::kRobotLaser1;
  if (tag == "PARAM") return RecordKind::kParam;
  return RecordKind::kOther;
}

/// How FLASER scans of a log are completed: FLASER records carry neither of these.
struct FlaserSettings {
  Pose2 T_robot_sensor;      ///< from PARAM robot_frontlaser_offset
  double max_range_m = 0.0;  ///< from a PARAM or the no-return rule
};

struct ParsedScan {
  LaserScan scan;
  std::size_t invalid_ranges = 0;
};

/// Checks that exactly `fixed` fields plus the trailer (timestamp [host [logger_timestamp]])
/// remain.
void CheckFieldCount(const Fields& fields, std::size_t fixed, const std::string& record) {
  const std::size_t remaining = fields.remaining();
  if (remaining >= fixed + 1 && remaining <= fixed + 3) return;
  const std::size_t full = fields.size() - remaining + fixed + 3;
  throw RecordError(record + " needs " + std::to_string(full) + " fields (" +
                    std::to_string(full - 2) + " or " + std::to_string(full - 1) +
                    " in older variants), got " + std::to_string(fields.size()));
}

/// timestamp [host [logger_timestamp]]: returns the timestamp.
double ParseTrailer(Fields& fields) {
  const double timestamp_s = fields.FiniteNumber("timestamp");
  if (fields.remaining() >= 1) fields.Text();  // host
  if (fields.remaining() >= 1) fields.Number("logger_timestamp");
  return timestamp_s;
}

/// n readings; NaN, inf and negative readings become NaN and are counted.
ParsedScan ParseReadings(Fields& fields, std::size_t n) {
  ParsedScan parsed;
  parsed.scan.ranges_m.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    double range_m = fields.Number("range reading");
    if (!std::isfinite(range_m) || range_m < 0.0) {
      range_m = kNaN;
      ++parsed.invalid_ranges;
    }
    parsed.scan.ranges_m.push_back(range_m);
  }
  return parsed;
}

/// FLASER beam directions: 180 deg field of view, beam 0 at -90 deg; the step is 180 deg / n
/// for even n (180, 360) and 180 deg / (n - 1) for odd n (181, 361).
std::vector<double> FlaserAngles(std::size_t n) {
  const std::size_t intervals = n % 2 == 0 ? n : std::max<std::size_t>(n - 1, 1);
  const double step_rad = M_PI / static_cast<double>(intervals);
  std::vector<double> angles_rad(n);
  for (std::size_t i = 0; i < n; ++i) angles_rad[i] = -M_PI_2 + static_cast<double>(i) * step_rad;
  return angles_rad;
}

// FLASER n r_1..r_n x y theta odom_x odom_y odom_theta timestamp host logger_timestamp
ParsedScan ParseFlaser(const std::vector<std::string_view>& tokens,
                       const FlaserSettings& settings) {
  Fields fields(tokens);
  fields.Text();
  const std::size_t n = fields.Count("reading count n", 1);
  CheckFieldCount(fields, n + 6, "FLASER with " + std::to_string(n) + " readings");
  ParsedScan parsed = ParseReadings(fields, n);
  fields.FinitePose("laser pose");
  const Pose2 T_odom_robot = fields.FinitePose("odometry pose");
  parsed.scan.timestamp_s = ParseTrailer(fields);
  parsed.scan.angles_rad = FlaserAngles(n);
  parsed.scan.max_range_m = settings.max_range_m;
  parsed.scan.T_robot_sensor = settings.T_robot_sensor;
  parsed.scan.T_odom_robot = T_odom_robot;
  return parsed;
}

struct RobotLaserHeader {
  double start_angle_rad = 0.0;
  double angular_resolution_rad = 0.0;
  double max_range_m = 0.0;
};

// laser_type start_angle fov angular_res max_range accuracy remission_mode
RobotLaserHeader ParseRobotLaserHeader(Fields& fields) {
  RobotLaserHeader header;
  fields.Number("laser_type");
  header.start_angle_rad = fields.FiniteNumber("start_angle");
  fields.FiniteNumber("fov");
  header.angular_resolution_rad = fields.FiniteNumber("angular_res");
  // Beam directions beyond a few turns are not a laser's (and overflow to inf further on).
  constexpr double kMaxAngle = 4.0 * M_PI;
  if (std::abs(header.start_angle_rad) > kMaxAngle ||
      std::abs(header.angular_resolution_rad) > kMaxAngle) {
    throw RecordError("start_angle or angular_res beyond +-4 pi rad");
  }
  header.max_range_m = fields.FiniteNumber("max_range");
  if (header.max_range_m <= 0.0) {
    throw RecordError("max_range " + internal::FormatNumber(header.max_range_m) + " is not > 0");
  }
  fields.Number("accuracy");
  fields.Number("remission_mode");
  return header;
}

// ROBOTLASER1 <header> n r_1..r_n n_rem rem_1..rem_n_rem laser_x laser_y laser_theta robot_x
// robot_y robot_theta tv rv fwd_safety side_safety turn_axis timestamp host logger_timestamp
ParsedScan ParseRobotLaser1(const std::vector<std::string_view>& tokens) {
  constexpr std::size_t kPoseAndMotionFields = 11;
  Fields fields(tokens);
  fields.Text();
  const RobotLaserHeader header = ParseRobotLaserHeader(fields);
  const std::size_t n = fields.Count("reading count n", 1);
  const std::string record = "ROBOTLASER1 with " + std::to_string(n) + " readings";
  if (fields.remaining() < n + 1 + kPoseAndMotionFields + 1) {
    throw RecordError(record + " has too few fields: " + std::to_string(fields.size()));
  }
  ParsedScan parsed = ParseReadings(fields, n);
  const std::size_t n_remissions = fields.Count("remission count", 0);
  CheckFieldCount(fields, n_remissions + kPoseAndMotionFields,
                  record + " and " + std::to_string(n_remissions) + " remissions");
  for (std::size_t i = 0; i < n_remissions; ++i) fields.Number("remission");
  const Pose2 T_odom_laser = fields.FinitePose("laser pose");
  const Pose2 T_odom_robot = fields.FinitePose("robot pose");
  for (const char* what : {"tv", "rv", "fwd_safety", "side_safety", "turn_axis"}) {
    fields.Number(what);
  }
  parsed.scan.timestamp_s = ParseTrailer(fields);
  parsed.scan.angles_rad.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    parsed.scan.angles_rad[i] =
        header.start_angle_rad + static_cast<double>(i) * header.angular_resolution_rad;
  }
  parsed.scan.max_range_m = header.max_range_m;
  parsed.scan.T_robot_sensor = T_odom_robot.Inverse() * T_odom_laser;
  parsed.scan.T_odom_robot = T_odom_robot;
  return parsed;
}

enum class ParamName { kFrontLaserOffset, kLaserMaxRange, kRobotLaserMax };

struct ParamValue {
  ParamName name;
  double value;
};

// PARAM name value [timestamp host logger_timestamp]; only the names ShapeSLAM uses are parsed.
std::optional<ParamValue> ParseParam(const std::vector<std::string_view>& tokens) {
  if (tokens.size() < 3) {
    throw RecordError("PARAM needs a name and a value, got " + std::to_string(tokens.size()) +
                      " fields");
  }
  ParamName name;
  if (tokens[1] == "robot_frontlaser_offset") {
    name = ParamName::kFrontLaserOffset;
  } else if (tokens[1] == "laser_front_laser_max_range") {
    name = ParamName::kLaserMaxRange;
  } else if (tokens[1] == "robot_front_laser_max") {
    name = ParamName::kRobotLaserMax;
  } else {
    return std::nullopt;
  }
  Fields fields(tokens);
  fields.Text();
  fields.Text();
  const double value = fields.FiniteNumber(std::string(tokens[1]).c_str());
  if (name != ParamName::kFrontLaserOffset && value <= 0.0) {
    throw RecordError(std::string(tokens[1]) + " " + internal::FormatNumber(value) + " is not > 0");
  }
  return ParamValue{name, value};
}

// ---------------------------------------------------------------------------------------------
// The survey pass.

/// The largest FLASER reading and the readings within the no-return band below it.
class LargestReadings {
 public:
  void Add(double range_m) {
    if (!(range_m >= 0.0)) return;  // NaN: no reading
    ++total_;
    if (range_m > largest_m_) {
      largest_m_ = range_m;
      const double floor_m = largest_m_ - Band();
      near_.erase(std::remove_if(near_.begin(), near_.end(), [&](double r) { return r < floor_m; }),
                  near_.end());
    }
    if (range_m >= largest_m_ - Band()) near_.push_back(range_m);
  }

  /// The max range rule of carmen_reader.h.
  double MaxRange() const {
    if (total_ == 0) return 1.0;
    const bool no_return_value =
        largest_m_ >= kMinNoReturnValue_m &&
        static_cast<double>(near_.size()) >= kMinNoReturnFraction * static_cast<double>(total_);
    if (!no_return_value) return largest_m_ + 1.0;
    // The no-return values: from L down while consecutive values lie within kNoReturnStep_m.
    std::vector<double> values = near_;
    std::sort(values.rbegin(), values.rend());
    std::size_t k = 0;
    while (k + 1 < values.size() && values[k] - values[k + 1] <= kNoReturnStep_m) ++k;
    return values[k] - kNoReturnBand_m;
  }

 private:
  // Scanners report "no return" as a value that varies a little (51.05-51.16 m on one log).
  double Band() const { return std::max(kNoReturnBand_m, kNoReturnBandFraction * largest_m_); }

  double largest_m_ = 0.0;
  std::size_t total_ = 0;
  std::vector<double> near_;
};

struct Survey {
  std::optional<double> frontlaser_offset_m;
  std::optional<double> laser_max_range_m;
  std::optional<double> robot_laser_max_m;
  LargestReadings flaser_readings;
  std::size_t flaser_records = 0;
  std::size_t robotlaser_records = 0;
  std::size_t malformed_laser_records = 0;
};

void AddParam(const ParamValue& param, Survey& survey) {
  std::optional<double>* slot = nullptr;
  switch (param.name) {
    case ParamName::kFrontLaserOffset:
      slot = &survey.frontlaser_offset_m;
      break;
    case ParamName::kLaserMaxRange:
      slot = &survey.laser_max_range_m;
      break;
    case ParamName::kRobotLaserMax:
      slot = &survey.robot_laser_max_m;
      break;
  }
  if (!slot->has_value()) *slot = param.value;  // the first value wins
}

/// Adds one record to the survey; throws RecordError when it is malformed.
void SurveyRecord(RecordKind kind, const std::vector<std::string_view>& tokens, Survey& survey) {
  switch (kind) {
    case RecordKind::kParam:
      if (const std::optional<ParamValue> param = ParseParam(tokens)) AddParam(*param, survey);
      return;
    case RecordKind::kFlaser:
      for (const double r : ParseFlaser(tokens, {}).scan.ranges_m) survey.flaser_readings.Add(r);
      ++survey.flaser_records;
      return;
    case RecordKind::kRobotLaser1:
      ParseRobotLaser1(tokens);
      ++survey.robotlaser_records;
      return;
    case RecordKind::kOther:
      return;
  }
}

/// Reads the whole log once. In strict mode the first malformed record throws LogError.
Survey SurveyLog(const std::string& path, bool strict) {
  Survey survey;
  LineReader lines(path);
  while (const std::optional<std::string_view> line = lines.Next()) {
    const std::vector<std::string_view> tokens = Tokenize(*line);
    if (tokens.empty()) continue;
    const RecordKind kind = KindOf(tokens[0]);
    try {
      SurveyRecord(kind, tokens, survey);
    } catch (const RecordError& e) {
      if (strict)
        throw LogError(path + ":" + std::to_string(lines.line_number()) + ": " + e.what());
      if (kind != RecordKind::kParam) ++survey.malformed_laser_records;
    }
  }
  return survey;
}

FlaserSettings SettingsFromSurvey(const Survey& survey) {
  FlaserSettings settings;
  settings.T_robot_sensor = Pose2(survey.frontlaser_offset_m.value_or(0.0), 0.0, 0.0);
  if (survey.laser_max_range_m) {
    settings.max_range_m = *survey.laser_max_range_m;
  } else if (survey.robot_laser_max_m) {
    settings.max_range_m = *survey.robot_laser_max_m;
  } else {
    settings.max_range_m = survey.flaser_readings.MaxRange();
  }
  return settings;
}

/// Throws LogError unless the first bytes of the file are text.
void CheckIsText(const std::string& path) {
  const std::string head = internal::ReadHead(path, internal::kSniffBytes);
  switch (internal::ClassifyContent(head)) {
    case internal::ContentKind::kEmpty:
      throw LogError(internal::EmptyLogMessage(path));
    case internal::ContentKind::kText:
      return;
    case internal::ContentKind::kMrptBinary:
    case internal::ContentKind::kBinary:
      break;
  }
  throw LogError(path + ": not a CARMEN log (binary content in the first " +
                 std::to_string(internal::kSniffBytes) + " bytes)");
}

}  // namespace

struct CarmenReader::Impl {
  explicit Impl(bool strict) : bookkeeping(strict) {}

  internal::ReaderBookkeeping bookkeeping;
  FlaserSettings flaser;
  bool use_robotlaser1 = false;  // the log has ROBOTLASER1 records: FLASER ones are ignored
  std::unique_ptr<LineReader> lines;
};

CarmenReader::CarmenReader(const std::string& path, const LogReaderOptions& options)
    : path_(path), impl_(std::make_unique<Impl>(options.strict)) {
  CheckIsText(path_);
  const Survey survey = SurveyLog(path_, options.strict);
  if (survey.flaser_records + survey.robotlaser_records == 0) {
    const std::size_t bad = survey.malformed_laser_records;
    throw LogError(path_ + ": no laser scans (FLASER/ROBOTLASER1) found" +
                   (bad > 0 ? " (" + std::to_string(bad) + " malformed laser records)" : ""));
  }
  impl_->flaser = SettingsFromSurvey(survey);
  impl_->use_robotlaser1 = survey.robotlaser_records > 0;
  if (impl_->use_robotlaser1 && survey.flaser_records > 0) {
    impl_->bookkeeping.Note(path_, std::to_string(survey.flaser_records) +
                                       " FLASER records ignored: the log has ROBOTLASER1 "
                                       "records of the same front laser");
  }
  impl_->lines = std::make_unique<LineReader>(path_);
}

CarmenReader::~CarmenReader() = default;

std::optional<LaserScan> CarmenReader::Next() {
  Impl& impl = *impl_;
  while (const std::optional<std::string_view> line = impl.lines->Next()) {
    const std::vector<std::string_view> tokens = Tokenize(*line);
    if (tokens.empty()) continue;
    const RecordKind kind = KindOf(tokens[0]);
    if (kind == RecordKind::kOther || (kind == RecordKind::kFlaser && impl.use_robotlaser1)) {
      continue;
    }
    const std::string where = path_ + ":" + std::to_string(impl.lines->line_number());
    try {
      if (kind == RecordKind::kParam) {
        ParseParam(tokens);  // applied by the survey; checked again to report it in order
        continue;
      }
      ParsedScan parsed =
          kind == RecordKind::kFlaser ? ParseFlaser(tokens, impl.flaser) : ParseRobotLaser1(tokens);
      impl.bookkeeping.AddInvalidRanges(parsed.invalid_ranges);
      impl.bookkeeping.Delivered(parsed.scan, where);
      return std::move(parsed.scan);
    } catch (const RecordError& e) {
      impl.bookkeeping.Malformed(where, e.what());
    }
  }
  return std::nullopt;
}

const LogReaderStats& CarmenReader::Stats() const { return impl_->bookkeeping.stats(); }

double CarmenReader::flaser_max_range_m() const { return impl_->flaser.max_range_m; }

}  // namespace shape_slam::io

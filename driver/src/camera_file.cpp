#include "shapesense/driver/camera_file.h"

#include <cmath>
#include <fstream>
#include <numbers>
#include <sstream>

#include <nlohmann/json.hpp>

#include "shapesense/driver/bounded_file.h"

namespace shapesense {
namespace {

std::string formatValue(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

// Reads the optional numeric fields of a camera.json object, naming the file in every error.
class CameraFields {
 public:
  CameraFields(const nlohmann::json& json, const std::string& label) : json_(json), label_(label) {}

  double number(const char* key, double fallback) const {
    if (!json_.contains(key)) return fallback;
    const auto& value = json_[key];
    if (!value.is_number()) fail(std::string("'") + key + "' is not a number");
    const double number = value.get<double>();
    if (!std::isfinite(number)) fail(std::string("'") + key + "' is not finite");
    return number;
  }

  /// A whole number in [1, kMaxImageSide]; 640.9 is refused rather than truncated.
  int side(const char* key, int fallback) const {
    const double value = number(key, fallback);
    if (!(value >= 1.0 && value <= kMaxImageSide) || value != std::floor(value)) {
      fail(std::string("'") + key + "' must be a positive whole number of pixels up to " +
           std::to_string(kMaxImageSide) + ", got " + formatValue(value));
    }
    return static_cast<int>(value);
  }

  [[noreturn]] void fail(const std::string& what) const {
    throw CameraFileError(label_ + ": " + what);
  }

 private:
  const nlohmann::json& json_;
  const std::string& label_;
};

// Smallest focal length (pixels) that keeps the field of view across `side` pixels under the
// limit.
double minFocalPx(int side) {
  const double half_fov = 0.5 * kMaxFieldOfViewDeg * std::numbers::pi / 180.0;
  return side / (2.0 * std::tan(half_fov));
}

void checkFocal(const CameraFields& fields, const char* key, double focal, int side) {
  if (!(focal > 0.0)) {
    fields.fail(std::string("'") + key + "' must be positive, got " + formatValue(focal));
  }
  const double lowest = minFocalPx(side);
  if (focal < lowest || focal > kMaxFocalPx) {
    fields.fail(std::string("'") + key + "' = " + formatValue(focal) +
                " px is not a depth camera's focal length for " + std::to_string(side) +
                " pixels: it must be positive, in [" + formatValue(lowest) + ", " +
                formatValue(kMaxFocalPx) + "] (a field of view under " +
                formatValue(kMaxFieldOfViewDeg) + " degrees)");
  }
}

void checkPrincipal(const CameraFields& fields, const char* key, double value, int side) {
  if (!(value >= 0.0 && value <= side)) {
    fields.fail(std::string("'") + key + "' = " + formatValue(value) +
                " puts the principal point outside the image (0.." + std::to_string(side) + ")");
  }
}

}  // namespace

RecordingCamera parseRecordingCamera(std::string_view text, const std::string& label) {
  nlohmann::json json;
  try {
    json = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    throw CameraFileError(label + ": not valid JSON: " + quoteExcerpt(e.what(), 200));
  }
  if (!json.is_object()) throw CameraFileError(label + ": must be a JSON object");
  const CameraFields fields(json, label);
  RecordingCamera camera;
  auto& k = camera.intrinsics;
  k.fx = fields.number("fx", k.fx);
  k.fy = fields.number("fy", k.fy);
  k.cx = fields.number("cx", k.cx);
  k.cy = fields.number("cy", k.cy);
  k.width = fields.side("width", k.width);
  k.height = fields.side("height", k.height);
  camera.depth_scale = fields.number("depth_scale", camera.depth_scale);
  checkFocal(fields, "fx", k.fx, k.width);
  checkFocal(fields, "fy", k.fy, k.height);
  checkPrincipal(fields, "cx", k.cx, k.width);
  checkPrincipal(fields, "cy", k.cy, k.height);
  if (!(camera.depth_scale >= kMinDepthScale && camera.depth_scale <= kMaxDepthScale)) {
    fields.fail("'depth_scale' must be positive, in [" + formatValue(kMinDepthScale) + ", " +
                formatValue(kMaxDepthScale) + "] depth units per metre, got " +
                formatValue(camera.depth_scale));
  }
  return camera;
}

RecordingCamera readRecordingCamera(const std::filesystem::path& dir) {
  const auto path = dir / "camera.json";
  std::error_code ec;
  if (!std::filesystem::exists(std::filesystem::symlink_status(path, ec))) return {};
  std::string text;
  try {
    text = readRegularFile(path, kMaxCameraFileBytes);
  } catch (const InputFileError& e) {
    throw CameraFileError(e.what());
  }
  return parseRecordingCamera(text, path.string());
}

void writeRecordingCamera(const std::filesystem::path& dir, const RecordingCamera& camera) {
  const auto& k = camera.intrinsics;
  nlohmann::json json = {{"fx", k.fx},
                         {"fy", k.fy},
                         {"cx", k.cx},
                         {"cy", k.cy},
                         {"width", k.width},
                         {"height", k.height},
                         {"depth_scale", camera.depth_scale}};
  std::ofstream out(dir / "camera.json");
  out << json.dump(2) << "\n";
  if (!out) throw std::runtime_error("cannot write " + (dir / "camera.json").string());
}

}  // namespace shapesense

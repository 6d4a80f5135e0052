#include "shapesense/driver/camera_file.h"

#include <fstream>

#include <nlohmann/json.hpp>

namespace shapesense {

RecordingCamera readRecordingCamera(const std::filesystem::path& dir) {
  RecordingCamera camera;
  const auto path = dir / "camera.json";
  if (!std::filesystem::exists(path)) return camera;
  std::ifstream in(path);
  nlohmann::json json;
  try {
    json = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw CameraFileError(path.string() + ": not valid JSON: " + e.what());
  }
  if (!json.is_object()) throw CameraFileError(path.string() + ": must be a JSON object");
  auto number = [&](const char* key, double fallback) {
    if (!json.contains(key)) return fallback;
    if (!json[key].is_number())
      throw CameraFileError(path.string() + ": '" + key + "' is not a number");
    return json[key].get<double>();
  };
  auto& k = camera.intrinsics;
  k.fx = number("fx", k.fx);
  k.fy = number("fy", k.fy);
  k.cx = number("cx", k.cx);
  k.cy = number("cy", k.cy);
  k.width = static_cast<int>(number("width", k.width));
  k.height = static_cast<int>(number("height", k.height));
  camera.depth_scale = number("depth_scale", camera.depth_scale);
  if (k.fx <= 0 || k.fy <= 0 || k.width <= 0 || k.height <= 0 || camera.depth_scale <= 0) {
    throw CameraFileError(path.string() +
                          ": fx, fy, width, height and depth_scale must all be positive");
  }
  return camera;
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

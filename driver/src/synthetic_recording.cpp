#include "shapesense/driver/synthetic_recording.h"

#include <cmath>
#include <fstream>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "shapesense/core/geometry/timestamp.h"
#include "shapesense/driver/tum_recording.h"

namespace shapesense::synthetic {

namespace {

nlohmann::json vec(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

nlohmann::json rows(const Eigen::MatrixXd& m) {
  nlohmann::json out = nlohmann::json::array();
  for (Eigen::Index r = 0; r < m.rows(); ++r) {
    nlohmann::json row = nlohmann::json::array();
    for (Eigen::Index c = 0; c < m.cols(); ++c) row.push_back(m(r, c));
    out.push_back(std::move(row));
  }
  return out;
}

nlohmann::json surfaceJson(const TruthSurface& s) {
  nlohmann::json out = {{"id", s.id},
                        {"name", s.name},
                        {"kind", s.kind == SurfaceKind::kPlane ? "plane" : "curved"},
                        {"object_id", s.object_id},
                        {"pixel_count", s.pixel_count}};
  if (s.kind == SurfaceKind::kPlane)
    out["plane"] = {s.plane.x(), s.plane.y(), s.plane.z(), s.plane.w()};
  return out;
}

nlohmann::json objectJson(const TruthObject& o) {
  nlohmann::json corners = nlohmann::json::array();
  for (const Eigen::Vector3d& c : o.corners) corners.push_back(vec(c));
  nlohmann::json out = {
      {"id", o.id},
      {"kind", o.kind},
      {"name", o.name},
      {"center", vec(o.center)},
      {"size", vec(o.size)},
      {"rotation", rows(o.rotation)},
      {"corners", std::move(corners)},
      {"image_box", {o.image_box.x, o.image_box.y, o.image_box.width, o.image_box.height}},
      {"pixel_count", o.pixel_count}};
  if (o.kind == "bowl") {
    out["upright"] = o.upright;
    out["view_class"] = o.view_class;
    out["view_elevation_deg"] = o.view_elevation_deg;
    out["rim_center"] = vec(o.rim_center);
    out["axis"] = vec(o.axis);
    out["rim_radius"] = o.rim_radius_m;
    out["depth"] = o.depth_m;
    out["shell_thickness"] = o.shell_thickness_m;
  }
  return out;
}

void writePng(const std::filesystem::path& path, const cv::Mat& image) {
  if (!cv::imwrite(path.string(), image)) throw std::runtime_error("cannot write " + path.string());
}

}  // namespace

nlohmann::json truthToJson(const TruthFrame& truth, const std::string& timestamp_text,
                           TimestampNs timestamp_ns, std::uint64_t sequence) {
  nlohmann::json surfaces = nlohmann::json::array();
  for (const TruthSurface& s : truth.surfaces) surfaces.push_back(surfaceJson(s));
  nlohmann::json objects = nlohmann::json::array();
  for (const TruthObject& o : truth.objects) objects.push_back(objectJson(o));
  return {{"timestamp", timestamp_text},
          {"timestamp_ns", timestamp_ns},
          {"sequence", sequence},
          {"world_from_camera", rows(truth.world_from_camera.matrix())},
          {"surfaces", std::move(surfaces)},
          {"objects", std::move(objects)}};
}

void writeSyntheticRecording(const std::filesystem::path& dir, const SceneParams& params,
                             std::uint64_t frames, TimestampNs start_ns, double fps) {
  if (!(fps > 0.0)) throw std::invalid_argument("writeSyntheticRecording: fps must be positive");
  SceneParams scene_params = params;
  scene_params.frame_rate_hz = fps;
  const SyntheticScene scene(scene_params);

  TumRecordingWriter writer(dir, RecordingCamera{params.intrinsics, 5000.0});
  const std::filesystem::path truth_dir = dir / "truth";
  std::filesystem::create_directories(truth_dir);
  std::ofstream jsonl(dir / "truth.jsonl", std::ios::out | std::ios::trunc);
  if (!jsonl) throw std::runtime_error("cannot write " + (dir / "truth.jsonl").string());

  for (std::uint64_t i = 0; i < frames; ++i) {
    const TimestampNs stamp = start_ns + std::llround(static_cast<double>(i) * 1e9 / fps);
    const RenderedFrame rendered = scene.render(i, stamp);
    writer.write(rendered.frame);
    // Same text as the writer's file names, so truth files pair with depth.txt lines.
    const std::string seconds = formatNsAsSeconds(stamp, 6);
    writePng(truth_dir / (seconds + ".surfaces.png"), rendered.truth.surface_labels);
    writePng(truth_dir / (seconds + ".objects.png"), rendered.truth.object_labels);
    jsonl << truthToJson(rendered.truth, seconds, stamp, i).dump() << '\n';
  }
  jsonl.flush();
  if (!jsonl) throw std::runtime_error("cannot write " + (dir / "truth.jsonl").string());
}

}  // namespace shapesense::synthetic

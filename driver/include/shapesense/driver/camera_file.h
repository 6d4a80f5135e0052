#pragma once
// camera.json of a recording: {"fx", "fy", "cx", "cy", "width", "height", "depth_scale"}.
// depth_scale is the PNG depth units per metre (5000 in the TUM layout).
//
// A recording may come from anywhere, and everything downstream sizes its work from these
// values, so they must describe a physical depth camera: width and height whole numbers in
// [1, kMaxImageSide]; fx and fy at most kMaxFocalPx and large enough that the field of view stays
// under kMaxFieldOfViewDeg (fx >= width / (2 tan(kMaxFieldOfViewDeg / 2))); the principal point
// inside the image; depth_scale in [kMinDepthScale, kMaxDepthScale].

#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>

#include "shapesense/core/geometry/camera.h"

namespace shapesense {

struct RecordingCamera {
  CameraIntrinsics intrinsics;  ///< Kinect v1 defaults when the file is absent
  double depth_scale = 5000.0;  ///< PNG depth units per metre
};

inline constexpr int kMaxImageSide = 16384;
inline constexpr double kMaxFocalPx = 20000.0;
/// Wider is no pinhole camera; it also bounds every pixel ray to < 6 times the optical axis.
inline constexpr double kMaxFieldOfViewDeg = 160.0;
/// Units per metre: a decimetre to 10 micrometres per unit.
inline constexpr double kMinDepthScale = 10.0;
inline constexpr double kMaxDepthScale = 100000.0;
/// camera.json is a few lines; a larger file is not one.
inline constexpr std::size_t kMaxCameraFileBytes = 64 * 1024;

/// A camera.json that exists but cannot be used; the message names the file and the field.
class CameraFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Reads `dir`/camera.json; returns the Kinect v1 defaults when the file does not exist and
/// throws CameraFileError when it is malformed or holds impossible values.
RecordingCamera readRecordingCamera(const std::filesystem::path& dir);

/// Parses the text of a camera.json (`label` names it in errors); fields left out keep the
/// Kinect v1 defaults. Throws CameraFileError as readRecordingCamera.
RecordingCamera parseRecordingCamera(std::string_view text, const std::string& label);

/// Writes `dir`/camera.json.
void writeRecordingCamera(const std::filesystem::path& dir, const RecordingCamera& camera);

}  // namespace shapesense

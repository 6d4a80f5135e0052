#pragma once
// camera.json of a recording: {"fx", "fy", "cx", "cy", "width", "height", "depth_scale"}.
// depth_scale is the PNG depth units per metre (5000 in the TUM layout).

#include <filesystem>
#include <stdexcept>
#include <string>

#include "shapesense/core/camera.h"

namespace shapesense {

struct RecordingCamera {
  CameraIntrinsics intrinsics;  ///< Kinect v1 defaults when the file is absent
  double depth_scale = 5000.0;  ///< PNG depth units per metre
};

/// A camera.json that exists but cannot be used; the message names the file and the field.
class CameraFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Reads `dir`/camera.json; returns the Kinect v1 defaults when the file does not exist and
/// throws CameraFileError when it is malformed or holds impossible values.
RecordingCamera readRecordingCamera(const std::filesystem::path& dir);

/// Writes `dir`/camera.json.
void writeRecordingCamera(const std::filesystem::path& dir, const RecordingCamera& camera);

}  // namespace shapesense

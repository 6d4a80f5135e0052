#pragma once
// The object model file: JSON, versioned, one file per taught object (`<name>.json` in the
// daemon's object models folder).
//
// Format "shapesense-object-model", version 2 (version 1 files, whose features used another
// local frame, are refused with "teach it again"):
// {
//   "format": "shapesense-object-model", "version": 2,
//   "name": "mug",                                  // see isValidObjectModelName
//   "descriptor": {"support_radius_m", "height_image_size", "cells", "voxel_m"},
//                                                   // what the features were computed with; a
//                                                   // scene must be described the same way
//   "surface": [[x, y, z, nx, ny, nz], ...],        // model frame, metres, unit normals
//   "features": [{"p": [x, y, z], "frame": [9, column-major], "response": r,
//                 "descriptor": [kShapeDescriptorSize floats]}, ...],
//   "box": {"centre": [3], "axes": [9, column-major], "size": [3]},
//   "outline_probes": [[x, y, z], ...]
// }
// Loading checks every count, size and value and throws std::runtime_error naming the file.

#include <filesystem>
#include <string>
#include <string_view>

#include "shapesense/core/recognition/object_model.h"

namespace shapesense {

inline constexpr int kObjectModelVersion = 3;
/// Largest model file read (bytes).
inline constexpr std::uintmax_t kMaxObjectModelFileBytes = 32u << 20;

/// 1-64 characters of letters, digits, '-', '_' and '.', not starting with '.': safe as a file
/// name and in a log line.
bool isValidObjectModelName(std::string_view name);

std::string objectModelToJson(const ObjectModel& model, const ObjectModelParams& params);
/// Throws std::runtime_error on malformed content, or when the model was described with other
/// descriptor parameters than `params`.
ObjectModel parseObjectModel(std::string_view json, const ObjectModelParams& params = {});

/// Writes atomically (a temporary file beside it, then a rename).
void saveObjectModel(const ObjectModel& model, const ObjectModelParams& params,
                     const std::filesystem::path& file);
/// Reads a regular file of at most kMaxObjectModelFileBytes.
ObjectModel loadObjectModel(const std::filesystem::path& file,
                            const ObjectModelParams& params = {});

}  // namespace shapesense

#pragma once
// Writes a synthetic scene as a TUM recording plus its ground truth, so the recording replays
// through the ordinary TUM source and tests can still check results against the truth.
//
// Layout of `dir` (TUM part written by TumRecordingWriter):
//   camera.json, depth.txt, rgb.txt, depth/<s>.png, rgb/<s>.png
//   truth/<s>.surfaces.png   uint16 PNG, TruthFrame::surface_labels
//   truth/<s>.objects.png    uint16 PNG, TruthFrame::object_labels
//   truth.jsonl              one JSON object per frame, in frame order
// where <s> is the frame's stamp in seconds with 6 decimals, exactly as in depth.txt.
//
// A truth.jsonl line (all geometry in that frame's camera frame, metres):
//   {"timestamp": "1700000000.033333",          // as in depth.txt
//    "timestamp_ns": 1700000000033333333, "sequence": 1,
//    "world_from_camera": [[r00,r01,r02,tx],[..],[..],[0,0,0,1]],   // rows; world z up
//    "surfaces": [{"id": 1, "name": "wall_left", "kind": "plane" | "curved",
//                  "plane": [nx,ny,nz,d],       // planes only; n.X + d = 0, d >= 0
//                  "object_id": 0, "pixel_count": 1234}, ...],
//    "objects": [{"id": 1, "kind": "table", "name": "table",
//                 "center": [x,y,z], "size": [sx,sy,sz], "rotation": [[..],[..],[..]],  // rows
//                 "corners": [[x,y,z] x 8], "image_box": [x,y,w,h], "pixel_count": 5678,
//                 // bowls only:
//                 "upright": true, "view_class": "middle", "view_elevation_deg": 35.2,
//                 "rim_center": [x,y,z], "axis": [x,y,z], "rim_radius": 0.1,
//                 "depth": 0.08, "shell_thickness": 0.006}, ...]}
// Field meanings are those of TruthSurface / TruthObject in synthetic_scene.h.

#include <cstdint>
#include <filesystem>
#include <string>

#include <nlohmann/json_fwd.hpp>

#include "shapesense/core/geometry/frame.h"
#include "shapesense/driver/synthetic_scene.h"

namespace shapesense::synthetic {

/// Renders frames 0 .. frames-1 of the scene (stamped start_ns + round(i * 1e9 / fps), with
/// params.frame_rate_hz replaced by fps) into `dir` as described above. Throws
/// std::runtime_error on I/O errors and std::invalid_argument on bad params.
void writeSyntheticRecording(const std::filesystem::path& dir, const SceneParams& params,
                             std::uint64_t frames, TimestampNs start_ns, double fps = 30.0);

/// The truth.jsonl object of one frame (`timestamp_text` is the depth.txt stamp).
nlohmann::json truthToJson(const TruthFrame& truth, const std::string& timestamp_text,
                           TimestampNs timestamp_ns, std::uint64_t sequence);

}  // namespace shapesense::synthetic

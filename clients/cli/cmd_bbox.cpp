#include <cstdio>
#include <iostream>

#include <opencv2/imgproc.hpp>

#include "commands.h"
#include "overlay.h"
#include "roi_arg.h"
#include "shapesense/core/boxes/box_estimation.h"
#include "shapesense/core/geometry/timestamp.h"
#include "time_arg.h"

namespace shapesense::cli {

void addBboxCommand(CLI::App& app, const GlobalOptions& global) {
  auto* cmd =
      app.add_subcommand("bbox", "The 3D box behind a 2D region of interest of the frame at T");
  struct Args {
    std::string at;
    std::string roi;
    int mode = 1;
    bool json = false;
    std::string out;
  };
  auto args = std::make_shared<Args>();
  cmd->add_option("--at", args->at,
                  "T in seconds (default: the newest frame; in mode 4 the newest the detectors "
                  "processed)");
  cmd->add_option("--roi", args->roi, "Two opposite corners x1,y1,x2,y2 in pixels (inclusive)")
      ->required();
  cmd->add_option("--mode", args->mode,
                  "1: ROI = front face, box turned to the view (default); 2: ROI contains an "
                  "axis-aligned box; 3: ROI = front face of an axis-aligned box; 4: the box of the "
                  "segments the ROI covers, upright on their support plane")
      ->capture_default_str();
  cmd->add_flag("--json", args->json, "Print JSON");
  cmd->add_option("--out", args->out, "Also draw the box over the frame into this PNG");
  cmd->callback([&global, args] {
    const auto [p1, p2] = parseRoiArgument(args->roi);
    Connection connection(global);
    v1::EstimateBoxRequest request;
    // Mode 4 boxes the detectors' segments: without --at, the newest frame they processed.
    request.set_at_ns(args->at.empty() && args->mode == 4 ? connection.newestProcessedFrame()
                                                          : parseTimeArgument(args->at));
    *request.mutable_p1() = p1;
    *request.mutable_p2() = p2;
    request.set_mode(static_cast<v1::BoxMode>(args->mode));
    v1::EstimateBoxResponse response;
    Connection::check(
        connection.stub().EstimateBox(connection.context().get(), request, &response));
    if (args->json) {
      std::cout << toJson(response) << "\n";
    } else {
      const auto& s = response.stats();
      std::cout << "frame " << formatNsAsSeconds(response.frame_timestamp_ns()) << " (seq "
                << response.frame_sequence() << "), mode " << static_cast<int>(response.mode())
                << "\n";
      std::printf("%s %.3f..%.3f m (mean %.3f, std %.3f over %u of %u valid pixels)\n",
                  s.range_from_origin() ? "distance" : "depth", s.near_m(), s.far_m(), s.mean_m(),
                  s.std_m(), s.used_pixels(), s.valid_pixels());
      const char* names[] = {"front top-left",    "front top-right", "front bottom-right",
                             "front bottom-left", "back top-left",   "back top-right",
                             "back bottom-right", "back bottom-left"};
      for (int i = 0; i < response.corners_size(); ++i) {
        const auto& c = response.corners(i);
        std::printf("  %-19s %8.3f %8.3f %8.3f\n", names[i], c.x(), c.y(), c.z());
      }
    }
    if (!args->out.empty()) {
      auto background = fetchFrameBackground(connection, response.frame_timestamp_ns());
      BoxCorners corners;
      for (int i = 0; i < 8; ++i) {
        const auto& c = response.corners(i);
        corners[i] = {c.x(), c.y(), c.z()};
      }
      cv::rectangle(background.bgr, cv::Point(p1.x(), p1.y()), cv::Point(p2.x(), p2.y()),
                    cv::Scalar(255, 255, 255), 1);
      drawBox(background.bgr, background.intrinsics, corners, cv::Scalar(0, 255, 255));
      writePng(args->out, background.bgr);
      if (!args->json) std::cout << "overlay written to " << args->out << "\n";
    }
  });
}

}  // namespace shapesense::cli

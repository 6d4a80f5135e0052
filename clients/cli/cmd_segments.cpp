#include <cstdio>
#include <iostream>

#include <opencv2/imgcodecs.hpp>

#include "commands.h"
#include "overlay.h"
#include "shapesense/core/geometry/timestamp.h"
#include "shapesense/core/segmentation/segmentation.h"
#include "time_arg.h"

namespace shapesense::cli {

void addSegmentsCommand(CLI::App& app, const GlobalOptions& global) {
  auto* cmd = app.add_subcommand("segments", "The depth segmentation of the frame at T");
  struct Args {
    std::string at;
    std::string method;
    std::string out;
    bool json = false;
  };
  auto args = std::make_shared<Args>();
  cmd->add_option("--at", args->at,
                  "T in seconds (default: the newest frame the detectors processed)");
  cmd->add_option("--method", args->method, listSegmentationMethods() + " (default: the daemon's)");
  cmd->add_option("--out", args->out,
                  "Write the region image (16-bit PNG) here, and a colour overlay beside it as "
                  "<name>.overlay.png");
  cmd->add_flag("--json", args->json, "Print JSON (statistics; the region image only with --out)");
  cmd->callback([&global, args] {
    Connection connection(global);
    v1::GetSegmentsRequest request;
    request.set_at_ns(args->at.empty() ? connection.newestProcessedFrame()
                                       : parseTimeArgument(args->at));
    request.set_method(args->method);
    request.set_skip_labels(args->out.empty());
    v1::GetSegmentsResponse response;
    Connection::check(
        connection.stub().GetSegments(connection.context().get(), request, &response));
    if (!args->out.empty()) {
      const auto& png = response.labels_png();
      const cv::Mat labels =
          cv::imdecode(std::vector<unsigned char>(png.begin(), png.end()), cv::IMREAD_UNCHANGED);
      const std::filesystem::path out = args->out;
      writePng(out, labels);
      auto background = fetchFrameBackground(connection, response.frame_timestamp_ns());
      paintLabels(background.bgr, labels);
      const auto overlay = out.parent_path() / (out.stem().string() + ".overlay.png");
      writePng(overlay, background.bgr);
      if (!args->json)
        std::cout << "regions written to " << out.string() << ", overlay to " << overlay.string()
                  << "\n";
    }
    if (args->json) {
      response.clear_labels_png();
      std::cout << toJson(response) << "\n";
      return;
    }
    std::cout << "frame " << formatNsAsSeconds(response.frame_timestamp_ns()) << ": "
              << response.segments_size() << " segments by " << response.method()
              << (response.computed_on_request() ? " (computed on request" : " (from the pipeline")
              << ", " << response.compute_ms() << " ms)\n";
    std::printf("%5s %8s %24s %24s %8s  %s\n", "id", "pixels", "centroid (m)", "normal", "rms mm",
                "box");
    for (const auto& s : response.segments()) {
      std::printf("%5u %8u %7.3f %7.3f %7.3f   %6.3f %6.3f %6.3f %8.2f  %d,%d %dx%d\n", s.id(),
                  s.pixels(), s.centroid().x(), s.centroid().y(), s.centroid().z(), s.normal().x(),
                  s.normal().y(), s.normal().z(), 1000 * s.plane_rms_m(), s.box().x(), s.box().y(),
                  s.box().width(), s.box().height());
    }
  });
}

}  // namespace shapesense::cli

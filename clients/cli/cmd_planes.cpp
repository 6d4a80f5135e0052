#include <cstdio>
#include <iostream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "commands.h"
#include "overlay.h"
#include "shapesense/core/geometry/timestamp.h"
#include "time_arg.h"

namespace shapesense::cli {
namespace {

// Draws each plane's boundary polygon, projected, in its label colour.
void drawPolygons(cv::Mat& bgr, const CameraIntrinsics& k, const v1::GetPlanesResponse& response) {
  for (const auto& plane : response.planes()) {
    std::vector<cv::Point> outline;
    for (const auto& p : plane.polygon()) {
      if (p.z() <= 0.01) continue;
      outline.emplace_back(cvRound(k.fx * p.x() / p.z() + k.cx),
                           cvRound(k.fy * p.y() / p.z() + k.cy));
    }
    if (outline.size() < 2) continue;
    const cv::Vec3b c = labelColour(plane.id());
    cv::polylines(bgr, outline, true, cv::Scalar(c[0], c[1], c[2]), 2, cv::LINE_AA);
    const auto& box = plane.box();
    cv::putText(bgr, std::to_string(plane.id()),
                {box.x() + box.width() / 2, box.y() + box.height() / 2}, cv::FONT_HERSHEY_SIMPLEX,
                0.5, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  }
}

}  // namespace

void addPlanesCommand(CLI::App& app, const GlobalOptions& global) {
  auto* cmd = app.add_subcommand("planes", "The planes of the frame at T (or accumulated up to T)");
  struct Args {
    std::string at;
    bool accumulated = false;
    bool json = false;
    std::string out;
  };
  auto args = std::make_shared<Args>();
  cmd->add_option("--at", args->at,
                  "T in seconds (default: the newest frame the detectors processed)");
  cmd->add_flag("--accumulated", args->accumulated,
                "The planes accumulated over time, not the frame's");
  cmd->add_flag("--json", args->json, "Print JSON");
  cmd->add_option("--out", args->out,
                  "Write an overlay PNG: plane regions and outlines over the frame");
  cmd->callback([&global, args] {
    Connection connection(global);
    v1::GetPlanesRequest request;
    request.set_at_ns(args->at.empty() ? connection.newestProcessedFrame()
                                       : parseTimeArgument(args->at));
    request.set_view(args->accumulated ? v1::GetPlanesRequest::ACCUMULATED
                                       : v1::GetPlanesRequest::FRAME);
    request.set_skip_labels(args->out.empty());
    request.set_skip_polygons(args->out.empty() && !args->json);
    v1::GetPlanesResponse response;
    Connection::check(connection.stub().GetPlanes(connection.context().get(), request, &response));
    if (!args->out.empty()) {
      auto background = fetchFrameBackground(connection, response.frame_timestamp_ns());
      if (!response.labels_png().empty()) {
        const auto& png = response.labels_png();
        paintLabels(background.bgr, cv::imdecode(std::vector<unsigned char>(png.begin(), png.end()),
                                                 cv::IMREAD_UNCHANGED));
      }
      drawPolygons(background.bgr, background.intrinsics, response);
      writePng(args->out, background.bgr);
    }
    if (args->json) {
      response.clear_labels_png();
      std::cout << toJson(response) << "\n";
      return;
    }
    std::cout << "frame " << formatNsAsSeconds(response.frame_timestamp_ns()) << ": "
              << response.planes_size() << (args->accumulated ? " accumulated" : "")
              << " planes by " << response.detector() << " (" << response.compute_ms() << " ms)\n";
    std::printf("%5s %26s %8s %9s %8s  %s\n", "id", "normal", "d (m)", "inliers", "rms mm", "box");
    for (const auto& p : response.planes()) {
      std::printf("%5u %8.4f %8.4f %8.4f %8.4f %9llu %8.2f  %d,%d %dx%d\n", p.id(), p.normal().x(),
                  p.normal().y(), p.normal().z(), p.d(),
                  static_cast<unsigned long long>(p.inliers()), 1000 * p.rms_m(), p.box().x(),
                  p.box().y(), p.box().width(), p.box().height());
    }
    if (!args->out.empty()) std::cout << "overlay written to " << args->out << "\n";
  });
}

}  // namespace shapesense::cli

#include <filesystem>
#include <iostream>

#include <opencv2/imgcodecs.hpp>

#include "commands.h"
#include "shapesense/core/geometry/timestamp.h"
#include "shapesense/driver/tum_recording.h"
#include "time_arg.h"

namespace shapesense::cli {

void addFrameCommand(CLI::App& app, const GlobalOptions& global) {
  auto* cmd = app.add_subcommand(
      "frame", "Fetch the frame at T and save it as a one-frame recording (TUM layout)");
  struct Args {
    std::string at;
    std::string out;
    bool json = false;
  };
  auto args = std::make_shared<Args>();
  cmd->add_option("--at", args->at, "T in seconds, e.g. 1700000000.033333 (default: the newest)");
  cmd->add_option("--out", args->out, "Directory to write depth.txt, rgb.txt, camera.json, images")
      ->required();
  cmd->add_flag("--json", args->json, "Print the frame's info as JSON");
  cmd->callback([&global, args] {
    v1::GetFrameRequest request;
    request.set_at_ns(parseTimeArgument(args->at));
    Connection connection(global);
    v1::GetFrameResponse response;
    Connection::check(connection.stub().GetFrame(connection.context().get(), request, &response));

    Frame frame;
    const auto& depth_png = response.depth_png();
    frame.depth = cv::imdecode(std::vector<unsigned char>(depth_png.begin(), depth_png.end()),
                               cv::IMREAD_UNCHANGED);
    if (!response.rgb_png().empty()) {
      const auto& rgb_png = response.rgb_png();
      frame.rgb = cv::imdecode(std::vector<unsigned char>(rgb_png.begin(), rgb_png.end()),
                               cv::IMREAD_COLOR);
    }
    if (frame.depth.empty() || frame.depth.type() != CV_16UC1) {
      throw std::runtime_error("the daemon sent a depth image that does not decode as 16-bit PNG");
    }
    frame.timestamp_ns = response.info().timestamp_ns();
    const auto& k = response.intrinsics();
    RecordingCamera camera;
    camera.intrinsics = {
        k.fx(), k.fy(), k.cx(), k.cy(), static_cast<int>(k.width()), static_cast<int>(k.height())};
    TumRecordingWriter writer(args->out, camera);
    writer.write(frame);
    if (args->json) {
      response.clear_depth_png();
      response.clear_rgb_png();
      std::cout << toJson(response) << "\n";
    } else {
      std::cout << "frame " << formatNsAsSeconds(frame.timestamp_ns) << " (seq "
                << response.info().sequence() << ") written to " << args->out << "\n";
    }
  });
}

}  // namespace shapesense::cli

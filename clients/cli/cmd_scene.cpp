#include <cstdio>
#include <fstream>
#include <iostream>

#include "commands.h"
#include "shapesense/core/geometry/timestamp.h"
#include "time_arg.h"

namespace shapesense::cli {
namespace {

std::optional<v1::PreviewRequest::Kind> previewKind(const std::string& name) {
  if (name.empty()) return v1::PreviewRequest::NONE;
  if (name == "colour") return v1::PreviewRequest::COLOUR;
  if (name == "depth") return v1::PreviewRequest::DEPTH;
  return std::nullopt;
}

const char* kindName(v1::SceneObject::Kind kind) {
  return kind == v1::SceneObject::BOWL ? "bowl" : "object";
}

void printScene(const v1::SceneUpdate& scene) {
  std::printf("frame %s (seq %llu), session %s: %d planes, %d things\n",
              formatNsAsSeconds(scene.info().timestamp_ns()).c_str(),
              static_cast<unsigned long long>(scene.info().sequence()), scene.session_id().c_str(),
              scene.planes_size(), scene.objects_size());
  for (const auto& plane : scene.planes()) {
    std::printf("  plane %3u  n %6.3f %6.3f %6.3f  d %.3f m  %d vertices  #%06x\n", plane.id(),
                plane.normal().x(), plane.normal().y(), plane.normal().z(), plane.d(),
                plane.polygon_xyz_size() / 3, plane.rgb());
  }
  for (const auto& thing : scene.objects()) {
    const auto& a = thing.corners(0);
    const auto& c = thing.corners(6);
    std::printf("  %-6s %3u  %5.1f x %5.1f x %5.1f cm  centre %6.3f %6.3f %6.3f m  seen %u",
                kindName(thing.kind()), thing.id(), 100 * thing.width_m(), 100 * thing.height_m(),
                100 * thing.depth_m(), (a.x() + c.x()) / 2, (a.y() + c.y()) / 2,
                (a.z() + c.z()) / 2, thing.frames_seen());
    if (thing.frames_missed() > 0) std::printf(", missed %u", thing.frames_missed());
    std::printf("\n");
  }
  for (const auto& taught : scene.taught_objects()) {
    std::printf("  taught %-20s centre %6.3f %6.3f %6.3f m  score %.3f\n", taught.name().c_str(),
                taught.box().centre().x(), taught.box().centre().y(), taught.box().centre().z(),
                taught.score());
  }
}

void printUpdateLine(const v1::SceneUpdate& update) {
  std::printf(
      "%s  seq %-6llu %s  planes %d (-%d)  things %d (-%d)  taught %d  %zu bytes",
      formatNsAsSeconds(update.info().timestamp_ns()).c_str(),
      static_cast<unsigned long long>(update.info().sequence()), update.full() ? "full " : "delta",
      update.planes_size(), update.removed_plane_ids_size(), update.objects_size(),
      update.removed_object_ids_size(), update.taught_objects_size(), update.ByteSizeLong());
  if (update.dropped_before() > 0) {
    std::printf("  (%llu dropped)", static_cast<unsigned long long>(update.dropped_before()));
  }
  std::printf("\n");
  std::fflush(stdout);
}

void writePreview(const std::string& path, const v1::SceneUpdate& update) {
  std::ofstream out(path, std::ios::binary);
  out.write(update.preview_jpeg().data(),
            static_cast<std::streamsize>(update.preview_jpeg().size()));
  if (!out) throw std::runtime_error("cannot write " + path);
}

}  // namespace

void addSceneCommand(CLI::App& app, const GlobalOptions& global) {
  auto* cmd = app.add_subcommand(
      "scene", "The scene model at T (stable planes, tracked boxes and bowls), or its updates");
  struct Args {
    std::string at;
    bool json = false;
    bool watch = false;
    double rate_hz = 0;
    unsigned count = 0;
    std::string preview;
    unsigned width = 0;
    std::string out;
  };
  auto args = std::make_shared<Args>();
  cmd->add_option("--at", args->at,
                  "T in seconds (default: the newest frame the detectors processed)");
  cmd->add_flag("--json", args->json, "Print JSON (one object per update with --watch)");
  cmd->add_flag("--watch", args->watch, "Print a line per update until Ctrl-C (WatchScene)");
  cmd->add_option("--rate", args->rate_hz, "With --watch: updates a second at most (0 = all)");
  cmd->add_option("--count", args->count, "With --watch: stop after N updates (0 = never)");
  cmd->add_option("--preview", args->preview, "Ask for a preview: colour or depth")
      ->check(CLI::IsMember({"colour", "depth"}));
  cmd->add_option("--width", args->width, "Preview width in pixels (default 320)");
  cmd->add_option("--out", args->out, "Write the (last) preview JPEG here")->needs("--preview");
  cmd->callback([&global, args] {
    v1::PreviewRequest preview;
    preview.set_kind(*previewKind(args->preview));
    preview.set_width(args->width);
    if (!args->watch) {
      Connection connection(global);
      v1::GetSceneRequest request;
      if (!args->at.empty()) request.set_at_ns(parseTimeArgument(args->at));
      *request.mutable_preview() = preview;
      v1::SceneUpdate scene;
      Connection::check(connection.stub().GetScene(connection.context().get(), request, &scene));
      if (!args->out.empty()) writePreview(args->out, scene);
      if (args->json) {
        std::cout << toJson(scene) << "\n";
      } else {
        printScene(scene);
      }
      return;
    }
    // A channel of its own that buffers little: a slow terminal gets the newest scene.
    const auto stub = v1::ShapeSense::NewStub(makeChannel(global, freshStreamArguments()));
    auto context = Connection::streamContext();
    v1::WatchSceneRequest request;
    request.set_max_rate_hz(args->rate_hz);
    *request.mutable_preview() = preview;
    auto reader = stub->WatchScene(context.get(), request);
    readStream(*reader, *context, args->count, [&](const v1::SceneUpdate& update) {
      if (!args->out.empty() && !update.preview_jpeg().empty()) writePreview(args->out, update);
      if (args->json) {
        std::cout << toJson(update) << std::endl;
      } else {
        printUpdateLine(update);
      }
    });
  });
}

}  // namespace shapesense::cli

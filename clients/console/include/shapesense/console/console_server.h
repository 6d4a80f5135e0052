#pragma once
// The operator's console: a local web server that serves one page and answers it from the
// daemon over gRPC. The browser only ever talks to this server; only gRPC crosses the network.
//
// Routes (JSON is protobuf's JSON mapping of the API's messages, field names as in the proto):
//   GET  /                       the page (index.html of the web root)
//   GET  /static/...             the page's modules and style sheet (the web root)
//   GET  /three/...              three.js (Debian's libjs-three)
//   GET  /api/events             server-sent events: `scene` (SceneUpdate of the WatchScene
//                                stream), `status` (each second), `link`, `record`; query:
//                                preview=colour|depth|none, width, quality, rate (updates/s),
//                                preview_rate (previews/s)
//   GET  /api/scene              GetScene; query: at_ns, preview=colour|depth|none, width, quality
//   GET  /api/frames             ListFrames
//   POST /api/box                EstimateBox; body: EstimateBoxRequest
//   GET  /api/segments.png       GetSegments of the frame at at_ns, coloured RGBA (0 = clear)
//   POST /api/record             Record; body: RecordRequest; progress as `record` events
//   POST /api/record/stop        cancels the running recording
// A failed call answers with the HTTP status of its gRPC code (http_status.h) and
// {"code": "OUT_OF_RANGE", "message": "<the daemon's words>"}; RESOURCE_EXHAUSTED (the daemon is
// busy and asks for a retry after a pause) is retried a few times within half a second first.

#include <filesystem>
#include <memory>
#include <string>

#include <grpcpp/channel.h>

namespace shapesense::console {

/// The two channels to the daemon: one for calls, one for the live streams, which a slow
/// browser must not let the transport buffer (the daemon keeps the newest update instead).
struct DaemonChannels {
  std::shared_ptr<grpc::Channel> calls;
  std::shared_ptr<grpc::Channel> streams;
};

struct ConsoleOptions {
  /// Address the page is served on, host:port; port 0 = any free port (see ConsoleServer::port).
  std::string listen = "127.0.0.1:8080";
  /// Folder of index.html and its modules; empty = defaultWebRoot().
  std::filesystem::path web_root;
  /// Folder of three.module.js and examples/jsm (libjs-three).
  std::filesystem::path three_root = "/usr/share/javascript/three";
  /// Deadline of each unary call to the daemon.
  double call_timeout_s = 10.0;
};

/// The web root of this install: share/shapesense/web beside the running binary (an install
/// moved to another prefix still finds its own), then the configured install prefix, then the
/// source tree of a build that was never installed.
std::filesystem::path defaultWebRoot();

/// True for addresses only this machine reaches (127.0.0.0/8, ::1, localhost).
bool isLoopbackListen(const std::string& listen);

/// Serves the console until stop(). Not copyable; one per process is enough.
class ConsoleServer {
 public:
  /// Binds `options.listen` at once; throws std::runtime_error naming the address when it cannot
  /// and when the web root holds no index.html.
  ConsoleServer(DaemonChannels daemon, ConsoleOptions options);
  ~ConsoleServer();
  ConsoleServer(const ConsoleServer&) = delete;
  ConsoleServer& operator=(const ConsoleServer&) = delete;

  /// The bound port (the free port chosen when options.listen asked for port 0).
  int port() const;
  /// "http://host:port/".
  std::string url() const;
  /// Answers requests on this thread until stop() is called (from any thread).
  void run();
  /// Ends run(), open event streams and a running recording.
  void stop();

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace shapesense::console

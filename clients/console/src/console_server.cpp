#include "shapesense/console/console_server.h"

#include <fstream>
#include <sstream>
#include <stdexcept>
#include <thread>

#include <sys/socket.h>

#include <httplib.h>
#include <nlohmann/json.hpp>

#include "event_channel.h"
#include "link_meter.h"
#include "proto_json.h"
#include "record_session.h"
#include "scene_forwarder.h"
#include "shapesense/console/http_status.h"
#include "shapesense/console/segment_colours.h"

namespace shapesense::console {
namespace {

constexpr auto kStatusPeriod = std::chrono::seconds(1);
// Every open page holds a thread in its event stream; the rest answer the page's calls.
constexpr std::size_t kHttpThreads = 16;

struct HostPort {
  std::string host;
  int port = 0;
};

HostPort parseListen(const std::string& listen) {
  const auto colon = listen.rfind(':');
  HostPort parsed;
  try {
    if (colon == std::string::npos) throw std::invalid_argument("no port");
    parsed.host = listen.substr(0, colon);
    std::size_t used = 0;
    parsed.port = std::stoi(listen.substr(colon + 1), &used);
    if (used != listen.size() - colon - 1 || parsed.port < 0 || parsed.port > 65535)
      throw std::invalid_argument("bad port");
  } catch (const std::exception&) {
    throw std::runtime_error("--listen '" + listen + "' is not HOST:PORT (e.g. 127.0.0.1:8080)");
  }
  if (parsed.host.size() >= 2 && parsed.host.front() == '[')
    parsed.host = parsed.host.substr(1, parsed.host.size() - 2);
  return parsed;
}

std::string readWholeFile(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

std::int64_t int64Param(const httplib::Request& request, const char* name) {
  if (!request.has_param(name)) return 0;
  try {
    return std::stoll(request.get_param_value(name));
  } catch (const std::exception&) {
    return -1;  // the daemon answers INVALID_ARGUMENT / OUT_OF_RANGE in its own words
  }
}

double doubleParam(const httplib::Request& request, const char* name, double fallback) {
  if (!request.has_param(name)) return fallback;
  try {
    return std::stod(request.get_param_value(name));
  } catch (const std::exception&) {
    return -1;
  }
}

/// preview=colour|depth|none, width, quality, preview_rate: the page's PreviewRequest.
v1::PreviewRequest previewFromQuery(const httplib::Request& request) {
  v1::PreviewRequest preview;
  const std::string kind = request.has_param("preview") ? request.get_param_value("preview") : "";
  preview.set_kind(kind == "depth"  ? v1::PreviewRequest::DEPTH
                   : kind == "none" ? v1::PreviewRequest::NONE
                                    : v1::PreviewRequest::COLOUR);
  preview.set_width(static_cast<std::uint32_t>(doubleParam(request, "width", 0)));
  preview.set_quality(static_cast<std::uint32_t>(doubleParam(request, "quality", 0)));
  preview.set_rate_hz(doubleParam(request, "preview_rate", 0));
  return preview;
}

void answerError(httplib::Response& response, const grpc::Status& status) {
  response.status = httpStatusFor(status.error_code());
  response.set_content(errorBody(status), "application/json");
}

void answerMessage(httplib::Response& response, const grpc::Status& status,
                   const google::protobuf::Message& message) {
  if (!status.ok()) return answerError(response, status);
  response.set_content(toJson(message), "application/json");
}

}  // namespace

class ConsoleServer::Impl {
 public:
  Impl(DaemonChannels daemon, ConsoleOptions options)
      : daemon_(std::move(daemon)),
        options_(std::move(options)),
        stub_(v1::ShapeSense::NewStub(daemon_.calls)) {
    if (options_.web_root.empty()) options_.web_root = defaultWebRoot();
    if (!std::filesystem::is_regular_file(options_.web_root / "index.html")) {
      throw std::runtime_error("no index.html in the console's web root " +
                               options_.web_root.string() + " (--web-root)");
    }
    http_.new_task_queue = [] { return new httplib::ThreadPool(kHttpThreads); };
    // httplib's default adds SO_REUSEPORT, under which a second console on the same port binds
    // too and the kernel splits the pages between them; SO_REUSEADDR alone still allows a quick
    // restart on the port.
    http_.set_socket_options([](socket_t socket) {
      int yes = 1;
      ::setsockopt(socket, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
    });
    addStaticRoutes();
    addQueryRoutes();
    addEventRoute();
    addRecordRoutes();
    bind();
  }

  int port() const { return port_; }
  std::string url() const {
    const bool v6 = host_.find(':') != std::string::npos;
    return "http://" + (v6 ? "[" + host_ + "]" : host_) + ":" + std::to_string(port_) + "/";
  }
  void run() {
    in_run_ = true;
    if (!stopping_) http_.listen_after_bind();
    in_run_ = false;
  }
  void stop() {
    stopping_ = true;
    pages_.closeAll();
    {
      std::lock_guard lock(record_mutex_);
      if (recording_) recording_->cancel();
    }
    // httplib's stop() does nothing until listen_after_bind() has started serving, so a stop()
    // that comes right after run() was called asks again until run() returns.
    while (in_run_) {
      http_.stop();
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  }
  ~Impl() {
    stop();
    std::lock_guard lock(record_mutex_);
    recording_.reset();
  }

 private:
  void bind() {
    const HostPort where = parseListen(options_.listen);
    host_ = where.host;
    port_ = where.port == 0 ? http_.bind_to_any_port(where.host)
                            : (http_.bind_to_port(where.host, where.port) ? where.port : -1);
    if (port_ <= 0) {
      throw std::runtime_error("cannot listen on " + options_.listen +
                               " (in use, or not an address of this machine)");
    }
  }

  std::unique_ptr<grpc::ClientContext> callContext() const {
    auto context = std::make_unique<grpc::ClientContext>();
    context->set_deadline(
        std::chrono::system_clock::now() +
        std::chrono::milliseconds(static_cast<long>(options_.call_timeout_s * 1000)));
    return context;
  }

  /// Runs one unary call, counting its answer on the link meter. A daemon that has all the work
  /// it takes on answers RESOURCE_EXHAUSTED and asks for a retry after a pause; the console
  /// retries a few times so an operator sees a busy moment as a slower answer, not an error.
  template <typename Request, typename Response, typename Call>
  grpc::Status call(Call method, const Request& request, Response* response) {
    grpc::Status status;
    for (auto pause : {25, 50, 100, 200, 0}) {
      status = ((*stub_).*method)(callContext().get(), request, response);
      if (status.error_code() != grpc::RESOURCE_EXHAUSTED || pause == 0 || stopping_) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(pause));
    }
    if (status.ok()) meter_.received(response->ByteSizeLong());
    return status;
  }

  void addStaticRoutes() {
    for (const auto& [ext, mime] : {std::pair{"js", "text/javascript"},
                                    {"mjs", "text/javascript"},
                                    {"css", "text/css"},
                                    {"html", "text/html"},
                                    {"svg", "image/svg+xml"}}) {
      http_.set_file_extension_and_mimetype_mapping(ext, mime);
    }
    http_.set_mount_point("/static", options_.web_root.string());
    http_.set_mount_point("/three", options_.three_root.string());
    http_.Get("/", [this](const httplib::Request&, httplib::Response& response) {
      response.set_content(readWholeFile(options_.web_root / "index.html"), "text/html");
    });
  }

  void addQueryRoutes() {
    using Stub = v1::ShapeSense::Stub;
    http_.Get("/api/frames", [this](const httplib::Request& request, httplib::Response& response) {
      v1::ListFramesRequest query;
      query.set_from_ns(int64Param(request, "from_ns"));
      query.set_to_ns(int64Param(request, "to_ns"));
      query.set_limit(static_cast<std::uint32_t>(int64Param(request, "limit")));
      v1::ListFramesResponse frames;
      answerMessage(response, call(&Stub::ListFrames, query, &frames), frames);
    });
    http_.Get("/api/scene", [this](const httplib::Request& request, httplib::Response& response) {
      v1::GetSceneRequest query;
      query.set_at_ns(int64Param(request, "at_ns"));
      *query.mutable_preview() = previewFromQuery(request);
      v1::SceneUpdate scene;
      answerMessage(response, call(&Stub::GetScene, query, &scene), scene);
    });
    http_.Post("/api/box", [this](const httplib::Request& request, httplib::Response& response) {
      v1::EstimateBoxRequest query;
      if (auto parsed = fromJson(request.body, &query); !parsed.ok())
        return answerError(response, parsed);
      v1::EstimateBoxResponse box;
      answerMessage(response, call(&Stub::EstimateBox, query, &box), box);
    });
    http_.Get("/api/segments.png", [this](const httplib::Request& request,
                                          httplib::Response& response) {
      v1::GetSegmentsRequest query;
      query.set_at_ns(int64Param(request, "at_ns"));
      v1::GetSegmentsResponse segments;
      const auto status = call(&Stub::GetSegments, query, &segments);
      if (!status.ok()) return answerError(response, status);
      response.set_header("X-Frame-Timestamp-Ns", std::to_string(segments.frame_timestamp_ns()));
      response.set_content(colourSegmentLabels(segments.labels_png()), "image/png");
    });
  }

  /// One page's event stream: its own WatchScene stream, and a `status` event each second.
  void addEventRoute() {
    http_.Get("/api/events", [this](const httplib::Request& request, httplib::Response& response) {
      v1::WatchSceneRequest watch;
      watch.set_max_rate_hz(doubleParam(request, "rate", 0));
      *watch.mutable_preview() = previewFromQuery(request);
      auto page = std::make_shared<EventChannel>();
      pages_.add(page);
      page->pushNotice({"link", R"({"state":"connecting"})"});
      auto forwarder = std::make_shared<SceneForwarder>(daemon_.streams, watch, page, meter_);
      auto next_status = std::make_shared<std::chrono::steady_clock::time_point>();
      response.set_header("Cache-Control", "no-cache");
      response.set_chunked_content_provider(
          "text/event-stream",
          [this, page, next_status](std::size_t, httplib::DataSink& sink) {
            return writeNextEvent(*page, *next_status, sink);
          },
          [this, page, forwarder](bool) mutable {
            pages_.remove(page);
            forwarder.reset();  // closes the page's channel and the stream
          });
    });
  }

  bool writeNextEvent(EventChannel& page, std::chrono::steady_clock::time_point& next_status,
                      httplib::DataSink& sink) {
    if (stopping_ || page.closed()) return false;
    const auto now = std::chrono::steady_clock::now();
    std::optional<SseEvent> event;
    if (now >= next_status) {
      next_status = now + kStatusPeriod;
      event = statusEvent();
    } else {
      event = page.pop(std::chrono::duration_cast<std::chrono::milliseconds>(next_status - now));
    }
    if (!event) return !page.closed();
    const std::string wire = event->wire();
    return sink.write(wire.data(), wire.size());
  }

  /// {"status": GetStatusResponse, "link_bytes_per_s": N}, or "error" instead of "status".
  SseEvent statusEvent() {
    v1::GetStatusResponse status;
    auto context = callContext();
    context->set_deadline(std::chrono::system_clock::now() + kStatusPeriod);
    const grpc::Status result = stub_->GetStatus(context.get(), {}, &status);
    nlohmann::json body;
    if (result.ok()) {
      meter_.received(status.ByteSizeLong());
      body["status"] = nlohmann::json::parse(toJson(status));
    } else {
      body["error"] = nlohmann::json::parse(errorBody(result));
    }
    body["link_bytes_per_s"] = meter_.bytesLastSecond();
    return {"status", body.dump()};
  }

  void addRecordRoutes() {
    http_.Post("/api/record", [this](const httplib::Request& request, httplib::Response& response) {
      v1::RecordRequest record;
      if (auto parsed = fromJson(request.body, &record); !parsed.ok())
        return answerError(response, parsed);
      std::lock_guard lock(record_mutex_);
      if (recording_ && !recording_->finished()) {
        return answerError(response, {grpc::ABORTED,
                                      "a recording started from this console is running: stop "
                                      "it first"});
      }
      recording_.reset();
      recording_ = std::make_unique<RecordSession>(
          *stub_, record, [this](const SseEvent& event) { pages_.broadcast(event); }, meter_);
      const grpc::Status started = recording_->waitForStart(std::chrono::seconds(5));
      if (!started.ok()) return answerError(response, started);
      response.set_content(R"({"state":"recording"})", "application/json");
    });
    http_.Post("/api/record/stop", [this](const httplib::Request&, httplib::Response& response) {
      std::lock_guard lock(record_mutex_);
      if (recording_) recording_->cancel();
      response.set_content(R"({"state":"stopping"})", "application/json");
    });
  }

  DaemonChannels daemon_;
  ConsoleOptions options_;
  std::unique_ptr<v1::ShapeSense::Stub> stub_;
  LinkMeter meter_;
  EventChannels pages_;
  std::mutex record_mutex_;
  std::unique_ptr<RecordSession> recording_;
  std::atomic<bool> stopping_ = false;
  std::atomic<bool> in_run_ = false;
  std::string host_;
  int port_ = 0;
  httplib::Server http_;
};

ConsoleServer::ConsoleServer(DaemonChannels daemon, ConsoleOptions options)
    : impl_(std::make_unique<Impl>(std::move(daemon), std::move(options))) {}
ConsoleServer::~ConsoleServer() = default;
int ConsoleServer::port() const { return impl_->port(); }
std::string ConsoleServer::url() const { return impl_->url(); }
void ConsoleServer::run() { impl_->run(); }
void ConsoleServer::stop() { impl_->stop(); }

}  // namespace shapesense::console

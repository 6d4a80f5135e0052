// The console's HTTP routes against a real in-process daemon (TestServer): the page must get
// what the daemon says, in the API's JSON mapping, errors in the daemon's words.

#include <atomic>
#include <filesystem>
#include <thread>

#include <google/protobuf/util/json_util.h>
#include <grpcpp/create_channel.h>
#include <grpcpp/security/credentials.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "server_fixture.h"
#include "shapesense/console/console_server.h"
#include "shapesense/console/http_status.h"
#include "shapesense/console/segment_colours.h"
// Last: httplib.h brings <resolv.h>, whose `_res` macro breaks Eigen's headers included after it.
#include <httplib.h>

namespace shapesense::testing {
namespace {

using console::ConsoleOptions;
using console::ConsoleServer;

/// A console on a free loopback port for `daemon`, serving until destroyed.
class RunningConsole {
 public:
  explicit RunningConsole(TestServer& daemon, ConsoleOptions options = {}) {
    options.listen = "127.0.0.1:0";
    server_ = std::make_unique<ConsoleServer>(
        console::DaemonChannels{daemon.channel(), daemon.channel()}, options);
    thread_ = std::thread([this] { server_->run(); });
    client_ = std::make_unique<httplib::Client>("127.0.0.1", server_->port());
    client_->set_read_timeout(std::chrono::seconds(10));
  }
  ~RunningConsole() {
    server_->stop();
    thread_.join();
  }
  httplib::Client& http() { return *client_; }
  ConsoleServer& server() { return *server_; }

 private:
  std::unique_ptr<ConsoleServer> server_;
  std::thread thread_;
  std::unique_ptr<httplib::Client> client_;
};

template <typename Message>
Message parse(const std::string& json) {
  Message message;
  EXPECT_TRUE(google::protobuf::util::JsonStringToMessage(json, &message).ok()) << json;
  return message;
}

/// The JSON data of the first `event: NAME` in a server-sent event stream, or null.
nlohmann::json firstEvent(const std::string& stream, const std::string& name) {
  const std::string head = "event: " + name + "\ndata: ";
  const auto start = stream.find(head);
  if (start == std::string::npos) return nullptr;
  const auto end = stream.find('\n', start + head.size());
  if (end == std::string::npos) return nullptr;
  return nlohmann::json::parse(stream.substr(start + head.size(), end - start - head.size()));
}

class ConsoleServerTest : public ServerTest {
 protected:
  void SetUp() override { srv.addMany(5); }
};

TEST_F(ConsoleServerTest, BoxIsTheDaemonsBoxForTheSameRequest) {
  RunningConsole console(srv);
  v1::EstimateBoxRequest request;
  request.set_at_ns(kServerT0 + 2 * kFramePeriodNs);
  request.mutable_p1()->set_x(4);
  request.mutable_p1()->set_y(3);
  request.mutable_p2()->set_x(20);
  request.mutable_p2()->set_y(15);
  request.set_mode(v1::BOX_MODE_AXIS_ALIGNED_CONTAINED);
  v1::EstimateBoxResponse direct;
  ASSERT_TRUE(srv.stub().EstimateBox(clientContext().get(), request, &direct).ok());

  const std::string body = R"({"at_ns": ")" + std::to_string(request.at_ns()) +
                           R"(", "p1": {"x": 4, "y": 3}, "p2": {"x": 20, "y": 15},
                              "mode": "BOX_MODE_AXIS_ALIGNED_CONTAINED"})";
  auto answer = console.http().Post("/api/box", body, "application/json");
  ASSERT_TRUE(answer);
  ASSERT_EQ(answer->status, 200) << answer->body;
  const auto via_console = parse<v1::EstimateBoxResponse>(answer->body);
  EXPECT_EQ(via_console.frame_timestamp_ns(), direct.frame_timestamp_ns());
  ASSERT_EQ(via_console.corners_size(), 8);
  for (int i = 0; i < 8; ++i) {
    EXPECT_DOUBLE_EQ(via_console.corners(i).x(), direct.corners(i).x()) << "corner " << i;
    EXPECT_DOUBLE_EQ(via_console.corners(i).y(), direct.corners(i).y()) << "corner " << i;
    EXPECT_DOUBLE_EQ(via_console.corners(i).z(), direct.corners(i).z()) << "corner " << i;
  }
}

TEST_F(ConsoleServerTest, ADaemonErrorKeepsItsCodeAndMessage) {
  RunningConsole console(srv);
  v1::EstimateBoxRequest request;
  request.set_at_ns(kServerT0 - 1'000'000'000);  // a second before the cache
  request.mutable_p1()->set_x(4);
  request.mutable_p1()->set_y(3);
  request.mutable_p2()->set_x(20);
  request.mutable_p2()->set_y(15);
  v1::EstimateBoxResponse unused;
  const grpc::Status direct = srv.stub().EstimateBox(clientContext().get(), request, &unused);
  ASSERT_EQ(direct.error_code(), grpc::OUT_OF_RANGE);

  const std::string body = R"({"at_ns": ")" + std::to_string(request.at_ns()) +
                           R"(", "p1": {"x": 4, "y": 3}, "p2": {"x": 20, "y": 15}})";
  auto answer = console.http().Post("/api/box", body, "application/json");
  ASSERT_TRUE(answer);
  EXPECT_EQ(answer->status, 400);
  const auto error = nlohmann::json::parse(answer->body);
  EXPECT_EQ(error["code"], "OUT_OF_RANGE");
  EXPECT_EQ(error["message"], direct.error_message());
}

TEST_F(ConsoleServerTest, ABodyThatIsNoRequestIsInvalidArgument) {
  RunningConsole console(srv);
  auto answer = console.http().Post("/api/box", R"({"p1": "left"})", "application/json");
  ASSERT_TRUE(answer);
  EXPECT_EQ(answer->status, 400);
  EXPECT_EQ(nlohmann::json::parse(answer->body)["code"], "INVALID_ARGUMENT");
}

TEST_F(ConsoleServerTest, FramesAreTheDaemonsList) {
  RunningConsole console(srv);
  auto answer = console.http().Get("/api/frames");
  ASSERT_TRUE(answer);
  ASSERT_EQ(answer->status, 200);
  const auto frames = parse<v1::ListFramesResponse>(answer->body);
  ASSERT_EQ(frames.frames_size(), 5);
  EXPECT_EQ(frames.frames(4).timestamp_ns(), kServerT0 + 4 * kFramePeriodNs);
  // The JSON mapping: int64 as a string, so the page loses no nanosecond.
  EXPECT_EQ(nlohmann::json::parse(answer->body)["frames"][4]["timestamp_ns"],
            std::to_string(kServerT0 + 4 * kFramePeriodNs));
}

TEST_F(ConsoleServerTest, ServesThePageItsModulesAndThreeJs) {
  RunningConsole console(srv);
  auto page = console.http().Get("/");
  ASSERT_TRUE(page);
  EXPECT_EQ(page->status, 200);
  EXPECT_NE(page->body.find("importmap"), std::string::npos);
  auto module = console.http().Get("/static/main.js");
  ASSERT_TRUE(module);
  EXPECT_EQ(module->status, 200);
  // Browsers run an ES module only when it is served as JavaScript.
  EXPECT_EQ(module->get_header_value("Content-Type"), "text/javascript");
  auto three = console.http().Get("/three/build/three.module.js");
  ASSERT_TRUE(three);
  EXPECT_EQ(three->status, 200);
  EXPECT_NE(three->body.find("REVISION"), std::string::npos);
  auto controls = console.http().Get("/three/examples/jsm/controls/OrbitControls.js");
  ASSERT_TRUE(controls);
  EXPECT_EQ(controls->status, 200);
  auto outside = console.http().Get("/static/../../../CMakeLists.txt");
  ASSERT_TRUE(outside);
  EXPECT_NE(outside->status, 200);
}

TEST_F(ConsoleServerTest, EventsCarryTheDaemonsStatusEachSecond) {
  RunningConsole console(srv);
  std::string received;
  auto answer =
      console.http().Get("/api/events?preview=none", [&](const char* data, std::size_t length) {
        received.append(data, length);
        return received.find("event: status") == std::string::npos;
      });
  const auto event = firstEvent(received, "status");
  ASSERT_NE(event, nullptr) << received;
  const auto status = parse<v1::GetStatusResponse>(event["status"].dump());
  EXPECT_EQ(status.cache().frames(), 5u);
  EXPECT_TRUE(event.contains("link_bytes_per_s"));
}

TEST_F(ConsoleServerTest, SegmentsOfAFrameWithoutSegmentationAreTheDaemonsError) {
  RunningConsole console(srv);
  v1::GetSegmentsRequest request;
  request.set_at_ns(kServerT0);
  v1::GetSegmentsResponse unused;
  const auto direct = srv.stub().GetSegments(clientContext().get(), request, &unused);
  auto answer = console.http().Get("/api/segments.png?at_ns=" + std::to_string(kServerT0));
  ASSERT_TRUE(answer);
  if (direct.ok()) {
    EXPECT_EQ(answer->status, 200);
    EXPECT_EQ(answer->get_header_value("Content-Type"), "image/png");
  } else {
    EXPECT_EQ(answer->status, console::httpStatusFor(direct.error_code()));
    EXPECT_EQ(nlohmann::json::parse(answer->body)["message"], direct.error_message());
  }
}

TEST_F(ConsoleServerTest, ARecordingStartedFromThePageReportsItsProgressToThePage) {
  RunningConsole console(srv);
  std::string events;
  std::atomic<bool> done = false, listening = false;
  std::thread page([&] {
    httplib::Client http("127.0.0.1", console.server().port());
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    http.Get("/api/events?preview=none", [&](const char* data, std::size_t length) {
      events.append(data, length);
      listening = true;  // the console has registered the page: record events reach it
      done = events.find(R"("state":"done")") != std::string::npos;
      return !done && std::chrono::steady_clock::now() < give_up;
    });
  });
  std::atomic<bool> feeding = true;
  std::thread source([&] {  // the daemon records what its source delivers meanwhile
    for (int i = 5; feeding; ++i) {
      srv.add(kServerT0 + i * kFramePeriodNs);
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  });
  EXPECT_TRUE(waitFor([&] { return listening.load(); }));
  auto started = console.http().Post("/api/record", R"({"dir": "take-1", "seconds": 0.5})",
                                     "application/json");
  EXPECT_TRUE(started && started->status == 200) << (started ? started->body : "no answer");
  auto second = console.http().Post("/api/record", R"({"dir": "take-2", "seconds": 0.5})",
                                    "application/json");
  EXPECT_TRUE(second && second->status == 409)
      << "one recording at a time: " << (second ? second->body : "no answer");
  page.join();
  feeding = false;
  source.join();
  ASSERT_TRUE(done) << events;
  EXPECT_NE(events.find(R"("state":"recording")"), std::string::npos) << events;
  EXPECT_TRUE(std::filesystem::exists(srv.recordRoot() / "take-1" / "depth.txt"));
}

TEST(ConsoleEvents, AnUnreachableDaemonIsReportedAndRetried) {
  // A port nothing listens on: the console starts anyway and tells the page what is wrong.
  const auto nowhere = grpc::CreateChannel("127.0.0.1:1", grpc::InsecureChannelCredentials());
  ConsoleOptions options;
  options.listen = "127.0.0.1:0";
  ConsoleServer server({nowhere, nowhere}, options);
  std::thread serving([&] { server.run(); });
  httplib::Client http("127.0.0.1", server.port());
  http.set_read_timeout(std::chrono::seconds(10));
  std::string received;
  int links = 0;
  http.Get("/api/events", [&](const char* data, std::size_t length) {
    received.append(data, length);
    links = 0;
    for (auto at = received.find("event: link"); at != std::string::npos;
         at = received.find("event: link", at + 1))
      ++links;
    // connecting, then reconnecting at least twice: it keeps trying
    return !(links >= 3 && firstEvent(received, "status") != nullptr);
  });
  server.stop();
  serving.join();
  const auto status = firstEvent(received, "status");
  ASSERT_NE(status, nullptr) << received;
  EXPECT_EQ(status["error"]["code"], "UNAVAILABLE") << status.dump();
  const auto reconnect = received.find("\"state\":\"reconnecting\"");
  EXPECT_NE(reconnect, std::string::npos) << received;
  EXPECT_GE(links, 3) << received;
}

TEST(ConsoleListen, OnlyLoopbackCountsAsLocal) {
  EXPECT_TRUE(console::isLoopbackListen("127.0.0.1:8080"));
  EXPECT_TRUE(console::isLoopbackListen("localhost:8080"));
  EXPECT_TRUE(console::isLoopbackListen("[::1]:8080"));
  EXPECT_FALSE(console::isLoopbackListen("0.0.0.0:8080"));
  EXPECT_FALSE(console::isLoopbackListen("192.168.1.4:8080"));
  EXPECT_FALSE(console::isLoopbackListen("[::]:8080"));
}

TEST(ConsoleListen, APortInUseIsRefusedNamingTheAddress) {
  TestServer daemon;
  RunningConsole first(daemon);
  ConsoleOptions options;
  options.listen = "127.0.0.1:" + std::to_string(first.server().port());
  try {
    ConsoleServer second({daemon.channel(), daemon.channel()}, options);
    FAIL() << "a second console bound the same port";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(options.listen), std::string::npos) << e.what();
  }
}

TEST(ConsoleHttpStatus, FollowsTheGrpcMapping) {
  EXPECT_EQ(console::httpStatusFor(grpc::OUT_OF_RANGE), 400);
  EXPECT_EQ(console::httpStatusFor(grpc::FAILED_PRECONDITION), 400);
  EXPECT_EQ(console::httpStatusFor(grpc::PERMISSION_DENIED), 403);
  EXPECT_EQ(console::httpStatusFor(grpc::RESOURCE_EXHAUSTED), 429);
  EXPECT_EQ(console::httpStatusFor(grpc::UNAVAILABLE), 503);
  EXPECT_EQ(console::httpStatusFor(grpc::INTERNAL), 500);
}

TEST(SegmentColours, EachRegionGetsItsOwnOpaqueColourAndZeroIsClear) {
  cv::Mat labels(4, 6, CV_16UC1, cv::Scalar(0));
  labels(cv::Rect(0, 0, 3, 4)).setTo(1);
  labels(cv::Rect(3, 0, 2, 4)).setTo(2);
  std::vector<std::uint8_t> png;
  ASSERT_TRUE(cv::imencode(".png", labels, png));
  const std::string coloured = console::colourSegmentLabels(std::string(png.begin(), png.end()));
  const cv::Mat rgba = cv::imdecode(std::vector<std::uint8_t>(coloured.begin(), coloured.end()),
                                    cv::IMREAD_UNCHANGED);
  ASSERT_EQ(rgba.type(), CV_8UC4);
  ASSERT_EQ(rgba.size(), labels.size());
  EXPECT_EQ(rgba.at<cv::Vec4b>(0, 5)[3], 0);    // id 0: clear
  EXPECT_EQ(rgba.at<cv::Vec4b>(0, 0)[3], 255);  // regions: opaque
  EXPECT_EQ(rgba.at<cv::Vec4b>(0, 0), rgba.at<cv::Vec4b>(3, 2));
  EXPECT_NE(rgba.at<cv::Vec4b>(0, 0), rgba.at<cv::Vec4b>(0, 3));
  EXPECT_THROW(console::colourSegmentLabels("not a png"), std::invalid_argument);
}

}  // namespace
}  // namespace shapesense::testing

#pragma once
// The CLI's link to the daemon: one channel, one stub, and uniform error reporting.

#include <memory>
#include <string>

#include <google/protobuf/message.h>
#include <grpcpp/grpcpp.h>

#include "shapesense/v1/shapesense.grpc.pb.h"
#include "shapesense/v1/status_names.h"

namespace shapesense::cli {

using v1::statusCodeName;

/// Options every command shares.
struct GlobalOptions {
  std::string server = "127.0.0.1:50551";
  double timeout_s = 10.0;
  /// PEM CA bundle that signed the daemon's certificate; set: connect with TLS.
  std::string tls_ca;
  /// This client's PEM certificate and key, for a daemon that verifies clients (--tls-client-ca).
  std::string tls_cert;
  std::string tls_key;
  /// File whose first line is the bearer token sent with every call.
  std::string token_file;
};

/// The channel `options` describe: plain, or TLS when tls_ca is set, sending the token of
/// token_file with every call (only over TLS). Throws std::runtime_error for a file that cannot
/// be read or options that do not go together. `args`: gRPC channel arguments (default none).
std::shared_ptr<grpc::Channel> makeChannel(const GlobalOptions& options,
                                           const grpc::ChannelArguments& args = {});

/// Channel arguments under which gRPC holds as little of a stream as it can (one message) for
/// a reader that is slow: the daemon's Watch keeps the newest summary for it instead, so what it
/// reads after a pause is fresh rather than what the transport's window buffered meanwhile.
grpc::ChannelArguments freshStreamArguments();

/// Thrown for a failed RPC; main() prints it to stderr and exits non-zero.
class RpcError : public std::runtime_error {
 public:
  explicit RpcError(const grpc::Status& status);
  grpc::StatusCode code() const { return code_; }

 private:
  grpc::StatusCode code_;
};

class Connection {
 public:
  explicit Connection(const GlobalOptions& options);
  v1::ShapeSense::Stub& stub() { return *stub_; }
  /// A client context with the configured deadline.
  std::unique_ptr<grpc::ClientContext> context() const;
  /// A client context without deadline, for streams the user ends.
  static std::unique_ptr<grpc::ClientContext> streamContext();
  /// Throws RpcError unless `status` is OK.
  static void check(const grpc::Status& status);

  /// Capture time of the newest cached frame the detectors have processed, or 0 (= the newest)
  /// when none is. Detector queries without --at use it: when the source runs faster than the
  /// detectors, the newest frame is usually still being processed (or skipped), and "the
  /// newest planes" is what a person asking without a time means.
  std::int64_t newestProcessedFrame();

 private:
  GlobalOptions options_;
  std::unique_ptr<v1::ShapeSense::Stub> stub_;
};

/// Reads a server stream until it ends or `count` messages were read (0 = no limit; the call is
/// then cancelled), handing each to `on_message`; a failed stream throws RpcError, a cancelled
/// one does not.
template <class Message, class OnMessage>
void readStream(grpc::ClientReader<Message>& reader, grpc::ClientContext& context, unsigned count,
                OnMessage on_message) {
  Message message;
  unsigned received = 0;
  while (reader.Read(&message)) {
    on_message(message);
    if (count != 0 && ++received == count) {
      context.TryCancel();
      break;
    }
  }
  const grpc::Status status = reader.Finish();
  if (status.error_code() != grpc::CANCELLED) Connection::check(status);
}

/// A message as JSON with the proto field names (what --json prints).
std::string toJson(const google::protobuf::Message& message);

}  // namespace shapesense::cli

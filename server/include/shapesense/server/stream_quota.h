#pragma once
// How many Watch streams the daemon serves: at most so many per client and so many in all.
// Streams cost no thread (the callback API) but every one is written on every frame, so an
// unbounded number of them would still eat the pipeline's time. A client is the peer's address
// without its port: one machine (or every local process) with all its connections.

#include <cstddef>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>

namespace shapesense {

class StreamQuota {
 public:
  StreamQuota(std::size_t per_client, std::size_t total) : per_client_(per_client), total_(total) {}

  /// Held while a stream runs; gives its slot back when destroyed.
  class Lease {
   public:
    ~Lease();
    Lease(const Lease&) = delete;
    Lease& operator=(const Lease&) = delete;

   private:
    friend class StreamQuota;
    Lease(StreamQuota& quota, std::string client) : quota_(quota), client_(std::move(client)) {}
    StreamQuota& quota_;
    std::string client_;
  };

  /// A slot for a stream of `peer` (grpc::ServerContext::peer()), or null with `refusal` saying
  /// which limit was reached.
  std::unique_ptr<Lease> tryAcquire(std::string_view peer, std::string& refusal);

  std::size_t open() const;

  /// "ipv4:10.0.0.7:41234" -> "ipv4:10.0.0.7", "ipv6:[::1]:5000" -> "ipv6:[::1]"; other forms
  /// (unix:PATH) stay as they are.
  static std::string clientOf(std::string_view peer);

 private:
  void release(const std::string& client);

  const std::size_t per_client_;
  const std::size_t total_;
  mutable std::mutex mutex_;
  std::map<std::string, std::size_t, std::less<>> by_client_;
  std::size_t open_ = 0;
};

}  // namespace shapesense

#include "shapesense/server/stream_quota.h"

namespace shapesense {

StreamQuota::Lease::~Lease() { quota_.release(client_); }

std::string StreamQuota::clientOf(std::string_view peer) {
  if (!peer.starts_with("ipv4:") && !peer.starts_with("ipv6:")) return std::string(peer);
  const auto colon = peer.rfind(':');
  // "ipv6:[::1]:5000": the port follows the closing bracket; without one there is no port.
  if (peer.starts_with("ipv6:") && (colon == 0 || peer[colon - 1] != ']')) return std::string(peer);
  return std::string(peer.substr(0, colon));
}

std::unique_ptr<StreamQuota::Lease> StreamQuota::tryAcquire(std::string_view peer,
                                                            std::string& refusal) {
  std::string client = clientOf(peer);
  std::lock_guard lock(mutex_);
  if (open_ >= total_) {
    refusal = "the daemon serves " + std::to_string(total_) +
              " Watch streams already (shapesensed --max-watch-streams); retry later";
    return nullptr;
  }
  auto& mine = by_client_[client];
  if (mine >= per_client_) {
    refusal = client + " has " + std::to_string(mine) +
              " Watch streams open, the most one client may have (shapesensed "
              "--max-watch-per-client); close one first";
    if (mine == 0) by_client_.erase(client);
    return nullptr;
  }
  ++mine;
  ++open_;
  return std::unique_ptr<Lease>(new Lease(*this, std::move(client)));
}

std::size_t StreamQuota::open() const {
  std::lock_guard lock(mutex_);
  return open_;
}

void StreamQuota::release(const std::string& client) {
  std::lock_guard lock(mutex_);
  --open_;
  const auto it = by_client_.find(client);
  if (it != by_client_.end() && --it->second == 0) by_client_.erase(it);
}

}  // namespace shapesense

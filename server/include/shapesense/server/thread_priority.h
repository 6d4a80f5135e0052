#pragma once
// Thread priorities of the daemon. The detector thread must keep its core however many calls
// arrive, and a process without privileges can only lower priorities, so everything else is
// lowered: the query workers, and gRPC's own threads (which receive, refuse and write calls), by
// starting the gRPC server from a thread that already runs at a higher nice value. Linux keeps
// a nice value per thread and a new thread inherits its creator's.

#include <functional>

namespace shapesense {

/// Sets the calling thread's nice value (0..19; never raises priority). False when the system
/// refused.
bool setThisThreadNice(int nice);

/// Runs `work` on a new thread at `nice` and waits for it, so the threads `work` starts inherit
/// that priority. Rethrows what `work` threw.
void runAtNice(int nice, const std::function<void()>& work);

}  // namespace shapesense

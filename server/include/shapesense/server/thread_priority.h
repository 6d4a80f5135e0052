#pragma once
// Thread priorities and names of the daemon. The pipeline's threads must keep their core however
// many calls arrive. Everything else is lowered: the query workers, and gRPC's own threads (which
// receive, refuse and write calls), by starting the gRPC server from a thread that already runs
// at a higher nice value. Where the system allows it (root, CAP_SYS_NICE, or an RLIMIT_NICE such
// as the unit's LimitNICE=), the pipeline's threads are also raised above every other process's
// default, so clients on the same machine (a load test, a local viewer) cannot take their core
// either. Linux keeps a nice value per thread and a new thread inherits its creator's.

#include <functional>

namespace shapesense {

/// Sets the calling thread's nice value (-20..19). A value below the thread's own raises its
/// priority, which needs root, CAP_SYS_NICE or an RLIMIT_NICE that allows it. False when the
/// system refused; the thread then keeps its nice value.
bool setThisThreadNice(int nice);

/// The calling thread's nice value.
int thisThreadNice();

/// Names the calling thread for `top -H`, `ps -L` and debuggers (at most 15 characters are kept).
void nameThisThread(const char* name);

/// Runs `work` on a new thread at `nice` and waits for it, so the threads `work` starts inherit
/// that priority. Rethrows what `work` threw.
void runAtNice(int nice, const std::function<void()>& work);

}  // namespace shapesense

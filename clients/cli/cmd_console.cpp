// `shapesense console`: the operator's web console on this machine, answered from the daemon
// over gRPC (clients/console). Runs until Ctrl-C.

#include <csignal>
#include <iostream>
#include <thread>

#include "commands.h"
#include "shapesense/console/console_server.h"

namespace shapesense::cli {
namespace {

/// gRPC waits up to two minutes between attempts to reach a daemon that went away; an operator
/// watching the page wants it back within a couple of seconds of the daemon's restart.
grpc::ChannelArguments reconnectSoon(grpc::ChannelArguments args) {
  args.SetInt(GRPC_ARG_INITIAL_RECONNECT_BACKOFF_MS, 250);
  args.SetInt(GRPC_ARG_MIN_RECONNECT_BACKOFF_MS, 250);
  args.SetInt(GRPC_ARG_MAX_RECONNECT_BACKOFF_MS, 2000);
  return args;
}

}  // namespace

void addConsoleCommand(CLI::App& app, const GlobalOptions& global) {
  auto* cmd = app.add_subcommand(
      "console",
      "Serve the operator's web console (live 2D and 3D scene, boxes from a drawn rectangle, "
      "time slider, status, recording) on this machine until Ctrl-C");
  auto options = std::make_shared<console::ConsoleOptions>();
  cmd->add_option("--listen", options->listen,
                  "Address the page is served on (port 0: any free port); anything but "
                  "loopback lets other machines use the daemon through this console")
      ->capture_default_str();
  cmd->add_option("--web-root", options->web_root,
                  "Folder of the page (default: " + console::defaultWebRoot().string() + ")");
  cmd->callback([&global, options] {
    // Ctrl-C and SIGTERM are taken by sigwait below, so every thread started from here on
    // (gRPC's, the web server's) leaves them to it.
    sigset_t stop_signals;
    sigemptyset(&stop_signals);
    sigaddset(&stop_signals, SIGINT);
    sigaddset(&stop_signals, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);

    options->call_timeout_s = global.timeout_s;
    console::DaemonChannels daemon{makeChannel(global, reconnectSoon({})),
                                   makeChannel(global, reconnectSoon(freshStreamArguments()))};
    console::ConsoleServer server(daemon, *options);
    if (!console::isLoopbackListen(options->listen)) {
      std::cerr << "shapesense console: warning: serving on " << options->listen
                << ", not loopback: anyone who reaches it uses the daemon with this console's "
                   "credentials\n";
    }
    std::cout << "console for " << global.server << " at " << server.url() << std::endl;
    std::thread serving([&server] { server.run(); });
    int signal_number = 0;
    sigwait(&stop_signals, &signal_number);
    server.stop();
    serving.join();
  });
}

}  // namespace shapesense::cli

// shapesense: the operator's command line client. See `shapesense --help`.

#include <iostream>

#include "commands.h"

int main(int argc, char** argv) {
  using namespace shapesense::cli;
  GlobalOptions global;
  CLI::App app{
      "shapesense: query a shapesensed daemon, record sources, make synthetic recordings, analyse "
      "recordings offline."};
  app.require_subcommand(1);
  app.add_option("--server", global.server, "Daemon address")->capture_default_str();
  app.add_option("--timeout", global.timeout_s, "Seconds to wait for an answer")
      ->capture_default_str();
  app.add_option("--tls-ca", global.tls_ca,
                 "Connect with TLS, trusting daemon certificates this PEM CA bundle signed");
  app.add_option("--tls-cert", global.tls_cert,
                 "With --tls-ca: this client's PEM certificate, for a daemon started with "
                 "--tls-client-ca");
  app.add_option("--tls-key", global.tls_key, "With --tls-cert: this client's PEM private key");
  app.add_option("--token-file", global.token_file,
                 "Send the bearer token on this file's first line with every call (needs "
                 "--tls-ca)");
  addStatusCommand(app, global);
  addFramesCommand(app, global);
  addFrameCommand(app, global);
  addWatchCommand(app, global);
  addBboxCommand(app, global);
  addSegmentsCommand(app, global);
  addPlanesCommand(app, global);
  addBowlsCommand(app, global);
  addRecordCommand(app, global);
  addSynthCommand(app);
  addAnalyzeCommand(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const RpcError& e) {
    std::cerr << "shapesense: " << e.what();
    if (e.code() == grpc::UNAVAILABLE)
      std::cerr << " (is shapesensed running on " << global.server << "?)";
    std::cerr << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "shapesense: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

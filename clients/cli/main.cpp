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
  addGlobalOptions(app, global);
  addStatusCommand(app, global);
  addFramesCommand(app, global);
  addFrameCommand(app, global);
  addWatchCommand(app, global);
  addBboxCommand(app, global);
  addSegmentsCommand(app, global);
  addPlanesCommand(app, global);
  addBowlsCommand(app, global);
  addSceneCommand(app, global);
  addRecordCommand(app, global);
  addTeachCommand(app, global);
  addObjectsCommand(app, global);
  addFindCommand(app, global);
  addConsoleCommand(app, global);
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

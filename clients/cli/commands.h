#pragma once
// Each `shapesense` subcommand registers itself on the app; its code lives in cmd_<name>.cpp.

#include <CLI/CLI.hpp>

#include "connection.h"

namespace shapesense::cli {

/// --server, --timeout and the transport options (--tls-ca, --tls-cert, --tls-key,
/// --token-file) every daemon command shares.
void addGlobalOptions(CLI::App& app, GlobalOptions& global);

void addStatusCommand(CLI::App& app, const GlobalOptions& global);
void addFramesCommand(CLI::App& app, const GlobalOptions& global);
void addFrameCommand(CLI::App& app, const GlobalOptions& global);
void addWatchCommand(CLI::App& app, const GlobalOptions& global);
void addBboxCommand(CLI::App& app, const GlobalOptions& global);
void addSegmentsCommand(CLI::App& app, const GlobalOptions& global);
void addPlanesCommand(CLI::App& app, const GlobalOptions& global);
void addBowlsCommand(CLI::App& app, const GlobalOptions& global);
void addSceneCommand(CLI::App& app, const GlobalOptions& global);
void addRecordCommand(CLI::App& app, const GlobalOptions& global);
void addTeachCommand(CLI::App& app, const GlobalOptions& global);
void addObjectsCommand(CLI::App& app, const GlobalOptions& global);
void addFindCommand(CLI::App& app, const GlobalOptions& global);
void addConsoleCommand(CLI::App& app, const GlobalOptions& global);
void addSynthCommand(CLI::App& app);
void addAnalyzeCommand(CLI::App& app);

}  // namespace shapesense::cli

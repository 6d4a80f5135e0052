#include <iostream>

#include "commands.h"

namespace shapesense::cli {

void addSynthCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("synth", "Write a synthetic recording with its ground truth");
  cmd->callback([] { throw std::runtime_error("synth: not yet available"); });
}

}  // namespace shapesense::cli

#pragma once
// The subcommands of the `cutsim` program. Each one lives in its own src/cli/cmd_NAME.cpp and
// adds itself to the application through a register function called from main.cpp.
//
// A command reports bad input by throwing cutsim::InvalidInput (exit code 2, message
// "PATH:LINE: message" on stderr) and other failures by throwing cutsim::Error (exit code 1);
// main.cpp maps them. A command that returns normally exits with 0.
#include <CLI/CLI.hpp>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace cutsim::cli {

/// Thrown by a command that ends with a particular exit code after saying why itself. A run
/// stopped by SIGINT or SIGTERM gives the signal: the program then ends by that signal (as a
/// shell expects of a program interrupted, so that a loop of runs stops too), else with code.
struct ExitStatus {
  int code;
  int signal = 0;
};

/// `cutsim info MESH [--json]`: loads and checks a mesh, prints its counts (src/cli/cmd_info.cpp).
void registerInfoCommand(CLI::App& app);

/// `cutsim eval --rest REST --current CURRENT [...]`: energy and forces of
/// FastTriangularBendingSprings as one JSON object (src/cli/cmd_eval.cpp).
void registerEvalCommand(CLI::App& app);

/// `cutsim run SCENE [--out DIR] [--dump-final DIR] [--quiet]`: runs a scene file
/// (src/cli/cmd_run.cpp).
void registerRunCommand(CLI::App& app);
/// `cutsim resume CHECKPOINT`: continues a run from OUT/checkpoint.ckpt (src/cli/cmd_run.cpp).
void registerResumeCommand(CLI::App& app);

/// `cutsim components [KIND]`: the registered force fields, integrators and linear solvers with
/// their keys (src/cli/cmd_components.cpp).
void registerComponentsCommand(CLI::App& app);

/// `cutsim view RUN_DIR [-o FILE.html]`: the offline HTML player of a run (src/cli/cmd_view.cpp).
void registerViewCommand(CLI::App& app);

/// `cutsim import SCENE.scn -o SCENE.json [--steps N]`: a SOFA scene as a JSON scene
/// (src/cli/cmd_import.cpp).
void registerImportCommand(CLI::App& app);

/// `cutsim regress LIST [--refs DIR] [--write]`: SOFA's regression tests of state
/// (src/cli/cmd_regress.cpp).
void registerRegressCommand(CLI::App& app);

/// What an output option (`option`, for the message) may replace, checked before anything runs:
/// never one of `inputs` (the same file under any name, even with `force`); an existing file only
/// when this program wrote it (its first 4 KB hold `mark`) or `force`. Throws InvalidInput.
void checkReplaceable(const std::filesystem::path& target, const std::string& option,
                      const std::vector<std::filesystem::path>& inputs, std::string_view mark,
                      bool force);
/// The mark of a player page (cutsim view, cutsim run --html) and of an imported scene.
inline constexpr std::string_view kPlayerMark = "<meta name=\"generator\" content=\"cutsim view\">";
inline constexpr std::string_view kImportMark = "translated by cutsim's reader";

// Further commands are declared here.

}  // namespace cutsim::cli

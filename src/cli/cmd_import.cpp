// `cutsim import SCENE.scn -o SCENE.json [--steps N]`: writes the JSON scene a SOFA scene
// translates to (cutsim/core/sofa_scene.hpp); running it gives what running the .scn gives.
#include <filesystem>
#include <fstream>
#include <iostream>

#include "commands.hpp"
#include "cutsim/base/errors.hpp"
#include "cutsim/core/sofa_scene.hpp"

namespace cutsim::cli {
namespace {

struct ImportOptions {
  std::string scene, output;
  long steps = 100;
  bool force = false;
};

void importScene(const ImportOptions& options) {
  const std::filesystem::path out(options.output);
  std::error_code ec;
  if (std::filesystem::is_directory(out, ec))
    throw InvalidInput("-o", options.output + " is a folder, not a file");
  checkReplaceable(out, "-o", {options.scene}, kImportMark, options.force);
  if (!out.parent_path().empty())
    std::filesystem::create_directories(out.parent_path(), ec);  // checked on writing
  core::SofaImportOptions o;
  o.steps = options.steps;
  o.jsonDir = out.parent_path().empty() ? std::filesystem::path(".") : out.parent_path();
  const core::SofaSceneImport imported = core::importSofaScene(options.scene, o);
  for (const std::string& n : imported.notes) std::cerr << n << "\n";
  core::sceneFromSofa(imported);  // every check of a scene, before anything is written
  const std::filesystem::path tmp = out.string() + ".tmp";
  {
    std::ofstream f(tmp);
    f << imported.scene.dump(2) << "\n";
    if (!f) throw Error(tmp.string() + ": cannot write");
  }
  std::filesystem::rename(tmp, out, ec);
  if (ec) throw Error(out.string() + ": cannot write: " + ec.message());
  std::cout << "wrote " << out.string() << " (" << imported.scene["forceFields"].size()
            << " force fields, " << imported.scene["constraints"].size() << " constraints, "
            << imported.scene["ignored"].size() << " components ignored, " << imported.notes.size()
            << " notes)\n";
}

}  // namespace

void registerImportCommand(CLI::App& app) {
  auto options = std::make_shared<ImportOptions>();
  CLI::App* cmd =
      app.add_subcommand("import", "Translate a SOFA scene (.scn) into a cutsim JSON scene");
  cmd->add_option("scene", options->scene, "the SOFA scene (.scn)")->required();
  cmd->add_option("-o,--output", options->output, "the JSON scene to write")->required();
  cmd->add_flag("--force", options->force,
                "replace an existing file that is not a scene this command wrote (never the "
                "input)");
  cmd->add_option("--steps", options->steps,
                  "the number of steps the JSON scene runs (default 100)")
      ->check(CLI::Range(1L, 1000000000L));
  cmd->callback([options] { importScene(*options); });
}

}  // namespace cutsim::cli

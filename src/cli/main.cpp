// The `cutsim` command-line program: subcommands (see commands.hpp) and the mapping of errors to
// exit codes: 0 success, 2 bad input or usage (message on stderr), 1 any other failure; a run
// stopped by SIGINT or SIGTERM ends by that signal after writing its outputs (a shell shows 130
// or 143).
#include <csignal>
#include <exception>
#include <iostream>

#include "commands.hpp"
#include "cutsim/base/errors.hpp"
#include "cutsim/core/version.hpp"

int main(int argc, char** argv) {
  CLI::App app{"Simulator of thin deformable surfaces that are cut, torn and carved while they run",
               "cutsim"};
  app.set_version_flag("--version", cutsim::core::versionString(),
                       "Print the version of cutsim and of its libraries, then exit");
  app.require_subcommand(1);

  // Every subcommand registers here, one line each.
  cutsim::cli::registerInfoCommand(app);
  cutsim::cli::registerEvalCommand(app);
  cutsim::cli::registerRunCommand(app);
  cutsim::cli::registerResumeCommand(app);
  cutsim::cli::registerComponentsCommand(app);
  cutsim::cli::registerViewCommand(app);
  cutsim::cli::registerImportCommand(app);
  cutsim::cli::registerRegressCommand(app);

  try {
    app.parse(argc, argv);  // runs the chosen subcommand's callback
  } catch (const cutsim::cli::ExitStatus& e) {
    if (e.signal != 0) {
      std::cout.flush();
      std::cerr.flush();
      std::signal(e.signal, SIG_DFL);
      std::raise(e.signal);
    }
    return e.code;
  } catch (const CLI::ParseError& e) {
    // --help and --version end here too, with exit code 0.
    return app.exit(e) == 0 ? 0 : 2;
  } catch (const cutsim::InvalidInput& e) {
    std::cerr << e.what() << '\n';  // already "PATH:LINE: message"
    return 2;
  } catch (const cutsim::Error& e) {
    std::cerr << "cutsim: error: " << e.what() << '\n';
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "cutsim: internal error: " << e.what() << '\n';
    return 1;
  }
  return 0;
}

// `cutsim view RUN_DIR [-o FILE.html] [--max-mb N] [--up AXIS] [--png FRAME --png-out FILE]`:
// writes the offline HTML player of a run (cutsim/view/player.hpp) and says where it is.
#include <unistd.h>

#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>

#include "commands.hpp"
#include "cutsim/base/errors.hpp"
#include "cutsim/view/player.hpp"

namespace cutsim::cli {
namespace {

struct ViewOptions {
  std::string run;
  std::string out;
  double maxMb = 48.0;
  std::string up = "auto";
  bool quiet = false;
  long png = -1;  ///< frame to render to a still image; -1 none
  std::string pngOut;
  bool force = false;
};

std::string shellQuote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

/// The page rendered by headless Chromium to a PNG, at frame `frame` (the page reads #frame=N).
void renderStill(const std::filesystem::path& html, long frame, const std::filesystem::path& png) {
  const char* candidates[] = {"chromium", "chromium-browser", "google-chrome"};
  std::string browser;
  for (const char* c : candidates) {
    if (std::system(("command -v " + std::string(c) + " >/dev/null 2>&1").c_str()) == 0) {
      browser = c;
      break;
    }
  }
  if (browser.empty())
    throw Error(
        "--png needs Chromium (Debian's package chromium), which is not installed; the page is "
        "written");
  const std::filesystem::path profile =
      std::filesystem::temp_directory_path() / ("cutsim-chromium-" + std::to_string(::getpid()));
  // A file URL: the path percent-encoded but for unreserved characters and '/'.
  std::string url = "file://";
  for (unsigned char c : std::filesystem::absolute(html).lexically_normal().string()) {
    if (std::isalnum(c) || c == '/' || c == '-' || c == '_' || c == '.' || c == '~') {
      url += char(c);
    } else {
      char hex[4];
      std::snprintf(hex, sizeof hex, "%%%02X", c);
      url += hex;
    }
  }
  url += "#frame=" + std::to_string(frame);
  const std::string command =
      browser +
      " --headless --no-sandbox --disable-gpu --enable-unsafe-swiftshader --use-angle=swiftshader "
      "--disable-background-networking --disable-component-update --no-first-run --disable-sync "
      "--hide-scrollbars --window-size=1280,800 --virtual-time-budget=10000 --user-data-dir=" +
      shellQuote(profile.string()) +
      " --screenshot=" + shellQuote(std::filesystem::absolute(png).string()) + " " +
      shellQuote(url) + " >/dev/null 2>&1";
  const int rc = std::system(command.c_str());
  std::error_code ec;
  std::filesystem::remove_all(profile, ec);
  if (rc != 0 || !std::filesystem::exists(png))
    throw Error("Chromium could not render " + html.string() + " to " + png.string() +
                " (exit status " + std::to_string(rc) + ")");
}

void view(const ViewOptions& o) {
  const std::filesystem::path dir(o.run);
  const std::filesystem::path html =
      o.out.empty() ? dir / "player.html" : std::filesystem::path(o.out);
  if (!(o.maxMb >= 0.1 && o.maxMb <= 4096.0))
    throw InvalidInput("--max-mb",
                       std::to_string(o.maxMb) + " is not a size between 0.1 and 4096 MB");
  if (std::filesystem::is_directory(html))
    throw InvalidInput("-o", html.string() + " is a folder, not a file");
  const std::filesystem::path parent = std::filesystem::absolute(html).parent_path();
  if (std::filesystem::is_directory(dir) &&
      !std::filesystem::is_directory(parent))  // else: the run's error
    throw InvalidInput("-o", html.string() + ": the folder " + parent.string() + " does not exist");
  if (!o.out.empty()) checkReplaceable(html, "-o", {}, kPlayerMark, o.force);
  view::PlayerOptions options;
  options.budgetBytes = std::size_t(o.maxMb * 1048576.0);
  options.up = o.up;
  const bool tty = !o.quiet && isatty(fileno(stderr));
  if (tty) {
    options.progress = [](std::size_t done, std::size_t total) {
      if (done == total || done % 16 == 0)
        std::fprintf(stderr, "\rpacking frame %zu/%zu", done, total);
      if (done == total) std::fputc('\n', stderr);
    };
  }
  const view::PlayerReport r = view::writePlayer(dir, html, options);
  std::cout << html.string() << "\n";
  if (!o.quiet) {
    std::cerr << "player of " << dir.string() << ": " << r.framesShown << " of " << r.framesInRun
              << " frames, " << view::describeSize(r.bytes)
              << (r.partial ? " (a partial run: the page says so)" : "")
              << "; open it in a browser (no network needed)\n";
    if (r.framesShown < r.framesInRun)
      std::cerr << "note: one frame in " << r.stride << " kept, and the last, to stay within "
                << o.maxMb << " MB (raise --max-mb to keep more)\n";
  }
  if (o.png >= 0) {
    if (std::size_t(o.png) >= r.framesShown)
      throw InvalidInput("--png", std::to_string(o.png) + " is not a frame of the page (0 to " +
                                      std::to_string(r.framesShown - 1) + ")");
    const std::filesystem::path png = o.pngOut.empty()
                                          ? html.parent_path() / (html.stem().string() + ".png")
                                          : std::filesystem::path(o.pngOut);
    renderStill(html, o.png, png);
    std::cout << png.string() << "\n";
  }
}

}  // namespace

void registerViewCommand(CLI::App& app) {
  auto options = std::make_shared<ViewOptions>();
  CLI::App* cmd = app.add_subcommand(
      "view",
      "Write a run's player: one offline HTML page that plays its frames back (prints its path)");
  cmd->add_option("run", options->run, "the run's folder (cutsim run --out DIR)")->required();
  cmd->add_option("-o,--output", options->out, "the page to write (default: RUN_DIR/player.html)");
  cmd->add_option(
      "--max-mb", options->maxMb,
      "the page's size budget in MB (default 48): beyond it one frame in k is kept, and the last");
  cmd->add_option("--up", options->up,
                  "the view's up axis: x, y, z, -x, -y, -z or auto (against gravity; default)");
  cmd->add_option("--png", options->png,
                  "also render this frame of the page (counted among the frames it keeps) to a PNG "
                  "(needs Chromium)");
  cmd->add_option("--png-out", options->pngOut,
                  "the PNG's path (default: beside the page, same name)");
  cmd->add_flag("--quiet", options->quiet, "print only the page's path");
  cmd->add_flag("--force", options->force,
                "with -o: replace an existing file that is not a player page");
  cmd->callback([options] { view(*options); });
}

}  // namespace cutsim::cli

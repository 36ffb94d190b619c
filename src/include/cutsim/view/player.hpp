#pragma once
// The offline HTML player of a run (`cutsim view RUN_DIR`, `cutsim run --html`): reads the run's
// folder (its ParaView collections, frames and steps.csv), packs the frames into one binary blob
// (arrays shared between frames when they are equal, as the triangles between two cuts) and
// writes one self-contained HTML page that embeds the blob (base64) and the player's script
// (three.js, bundled at build time from viewer/).
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

namespace cutsim::view {

/// The CSV rows a page holds at most (beyond: every k-th, and those at the frames' times).
inline constexpr std::size_t kMaxSeriesRows = 20000;

/// One frame of a run, as its files give it: points numbered densely as in the frame's surface.
struct Frame {
  double time = 0.0;
  std::vector<float> x;                  ///< 3 per point
  std::vector<float> rest;               ///< 3 per point (empty: displacement unknown)
  std::vector<float> v;                  ///< 3 per point (empty: speed unknown)
  std::vector<std::uint32_t> triangles;  ///< 3 per triangle
  std::vector<float> strain;             ///< per triangle
  std::vector<std::uint8_t> held;        ///< per point: 0 free, 1 fixed, 2 grasped (may be empty)
  bool hasBorders = false;               ///< the run has a border frame at this frame's time
  std::vector<std::uint32_t> borders;    ///< 2 per border edge
  std::vector<std::uint8_t> lips;        ///< per border edge: 1 a side of a cut or a tear
  std::vector<std::uint32_t> springs;    ///< 2 per bending spring
  std::vector<std::uint32_t> stitches;   ///< 2 per suture's thread
  std::vector<float> obstacleX;          ///< 3 per obstacle point
  std::vector<std::uint32_t> obstacleTriangles;
  std::vector<float> instrumentX;  ///< 6 per instrument segment (a scalpel's blade: tip, end)
};

/// The steps' series (steps.csv): numeric columns, one value per row.
struct Series {
  std::vector<std::string> names;
  std::vector<std::vector<double>> columns;  ///< columns[c][row]
  std::size_t rows() const { return columns.empty() ? 0 : columns.front().size(); }
};

/// What a run folder holds, before its frames are read.
struct RunFolder {
  std::filesystem::path dir;
  bool partial = false;  ///< only surface.partial.pvd: the run stopped or is still going
  std::vector<std::pair<double, std::string>> surface;  ///< (time, file) per frame
  std::vector<std::pair<double, std::string>> borders, springs, stitches, obstacles,
      instruments;  ///< may be empty
  std::optional<std::filesystem::path> csv;
  nlohmann::json info = nlohmann::json::object();  ///< run.json when the run wrote one (scene name,
                                                   ///< description, gravity)
};

/// Lists a run folder's frames. Throws InvalidInput ("DIR: ...") for a folder that is missing,
/// is not a cutsim run or has no frame; "FILE:LINE: ..." for a collection that cannot be read.
RunFolder scanRun(const std::filesystem::path& dir);

/// Reads frame `index` of the run (its surface and what the other collections have at the same
/// index). Throws InvalidInput naming the file and line of what cannot be read.
Frame readFrame(const RunFolder& run, std::size_t index);

/// Reads steps.csv (during a run, its temporary file); columns without a number in any row (the
/// solver's flags) are left out; a cell that is not a number reads as NaN.
Series readSeries(const std::filesystem::path& csv);

/// Packs frames into one blob of little-endian arrays (each at an 8-byte aligned offset) and the
/// JSON that describes them. An array equal to the previous frame's array of the same kind is
/// not stored twice: both frames refer to the same [offset, count].
class FramePacker {
 public:
  void add(const Frame& frame);
  /// The series, after the frames: at most about `maxRows` rows (every k-th, the last and the
  /// frames' rows, each frame's "row" its index among them, "csvRow" its row in the CSV).
  void setSeries(const Series& series, std::size_t maxRows = kMaxSeriesRows);
  /// {"frames": [{"t", "points", "triangles", "x": [offset, count], ...}], "series": {...}}
  const nlohmann::json& meta() const { return meta_; }
  const std::string& blob() const { return blob_; }

 private:
  struct Ref {
    std::size_t offset = 0, count = 0;
  };
  template <typename T>
  nlohmann::json put(const std::string& key, const std::vector<T>& values);
  nlohmann::json meta_ = {{"frames", nlohmann::json::array()}};
  std::string blob_;
  std::map<std::string, std::pair<Ref, std::string>> previous_;  // key -> (ref, bytes)
};

struct PlayerOptions {
  std::size_t budgetBytes = std::size_t(48)
                            << 20;  ///< the page's size beyond which frames are dropped
  std::string up = "auto";          ///< "x", "y", "z", "-z", ... or "auto"
  std::function<void(std::size_t done, std::size_t total)> progress;
};

/// What `writePlayer` wrote.
struct PlayerReport {
  std::size_t framesInRun = 0, framesShown = 0, bytes = 0;
  std::size_t stride = 1;  ///< one frame of the run in `stride` kept (the last always)
  bool partial = false;
};

/// Which frames of `count` to show within `budget` bytes when a frame takes about
/// `bytesPerFrame`: all of them, or every k-th from the first, always with the last.
std::vector<std::size_t> chooseFrames(std::size_t count, double bytesPerFrame, std::size_t budget);

/// A size for people: "3.3 MB" (MB of 2^20 bytes, as --max-mb counts them; one decimal).
std::string describeSize(std::size_t bytes);

/// Standard base64 (RFC 4648, with padding).
std::string base64(const std::string& bytes);

/// The player's page for a run folder, written atomically to `html`.
PlayerReport writePlayer(const std::filesystem::path& runDir, const std::filesystem::path& html,
                         const PlayerOptions& options = {});

/// The page itself, for a packed run.
void writePlayerPage(std::ostream& out, const nlohmann::json& meta, const std::string& blob);

/// The bundled player script (embedded at build time from viewer/dist/player.js).
std::string_view playerScript();

}  // namespace cutsim::view

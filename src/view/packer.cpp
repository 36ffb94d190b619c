// Packs a run's frames for the player page, chooses which frames fit the page's size budget and
// writes the page (player.hpp).
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

#include "cutsim/base/errors.hpp"
#include "cutsim/core/output.hpp"
#include "cutsim/view/player.hpp"

namespace cutsim::view {

namespace fs = std::filesystem;
using nlohmann::json;

static_assert(std::endian::native == std::endian::little, "the page reads little-endian arrays");

template <typename T>
json FramePacker::put(const std::string& key, const std::vector<T>& values) {
  std::string bytes(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(T));
  auto it = previous_.find(key);
  if (it != previous_.end() && it->second.second == bytes)
    return json::array({it->second.first.offset, it->second.first.count});
  while (blob_.size() % 8 != 0) blob_.push_back('\0');
  const Ref ref{blob_.size(), values.size()};
  blob_ += bytes;
  previous_[key] = {ref, std::move(bytes)};
  return json::array({ref.offset, ref.count});
}

void FramePacker::add(const Frame& f) {
  const std::size_t n = f.x.size() / 3, t = f.triangles.size() / 3;
  json j;
  j["t"] = f.time;
  j["points"] = n;
  j["triangles"] = t;
  j["x"] = put("x", f.x);
  j["tri"] = put("tri", f.triangles);
  j["strain"] = put("strain", f.strain);
  // Per-triangle means of the points' speeds and displacements from rest.
  auto perTriangle = [&](auto pointValue) {
    std::vector<float> out(t);
    for (std::size_t k = 0; k < t; ++k) {
      double s = 0.0;
      for (int c = 0; c < 3; ++c) s += pointValue(f.triangles[3 * k + std::size_t(c)]);
      out[k] = float(s / 3.0);
    }
    return out;
  };
  auto norm = [](const std::vector<float>& a, const std::vector<float>* b, std::size_t p) {
    double s = 0.0;
    for (std::size_t c = 0; c < 3; ++c) {
      const double d = double(a[3 * p + c]) - (b ? double((*b)[3 * p + c]) : 0.0);
      s += d * d;
    }
    return std::sqrt(s);
  };
  if (!f.v.empty())
    j["speed"] = put("speed", perTriangle([&](std::uint32_t p) { return norm(f.v, nullptr, p); }));
  if (!f.rest.empty())
    j["displacement"] =
        put("displacement", perTriangle([&](std::uint32_t p) { return norm(f.x, &f.rest, p); }));
  if (!f.held.empty()) {
    std::size_t fixed = 0, grasped = 0;
    for (std::uint8_t h : f.held) {
      fixed += h == 1;
      grasped += h == 2;
    }
    j["fixed"] = fixed;
    j["grasped"] = grasped;
    j["held"] = put("held", f.held);
  }
  if (f.hasBorders) {  // unknown otherwise (a run from before borders were written): null
    j["borders"] = f.lips.size();
    j["lipEdges"] = std::count(f.lips.begin(), f.lips.end(), std::uint8_t(1));
  } else {
    j["borders"] = nullptr;
    j["lipEdges"] = nullptr;
  }
  if (!f.borders.empty()) {
    j["border"] = put("border", f.borders);
    j["lip"] = put("lip", f.lips);
  }
  j["springs"] = f.springs.size() / 2;
  if (!f.springs.empty()) j["spring"] = put("spring", f.springs);
  if (!f.stitches.empty()) j["stitch"] = put("stitch", f.stitches);
  if (!f.obstacleX.empty()) {
    j["obstacleX"] = put("obstacleX", f.obstacleX);
    j["obstacleTri"] = put("obstacleTri", f.obstacleTriangles);
  }
  if (!f.instrumentX.empty()) j["instrumentX"] = put("instrumentX", f.instrumentX);
  meta_["frames"].push_back(std::move(j));
}

void FramePacker::setSeries(const Series& s, std::size_t maxRows) {
  // Each frame's row: the row at the frame's time (the CSV has one per step, the frames one per
  // `every` steps); none when the CSV has no such row (a run stopped between the two).
  const auto timeColumn = std::find(s.names.begin(), s.names.end(), "time");
  std::vector<long> frameRows;
  for (const json& f : meta_["frames"]) {
    long row = -1;
    if (timeColumn != s.names.end()) {
      const std::vector<double>& times = s.columns[std::size_t(timeColumn - s.names.begin())];
      const double t = f["t"].get<double>(), tolerance = 1e-12 * std::max(1.0, std::abs(t));
      const auto it = std::lower_bound(times.begin(), times.end(), t - tolerance);
      if (it != times.end() && std::abs(*it - t) <= tolerance) row = long(it - times.begin());
    }
    frameRows.push_back(row);
  }
  // Long runs: every k-th row, the last one and the frames' rows (the plots keep their shape;
  // the page stays small).
  const std::size_t rows = s.rows();
  const std::size_t stride = rows > maxRows && maxRows > 0 ? (rows + maxRows - 1) / maxRows : 1;
  std::vector<char> keep(rows, 0);
  for (std::size_t r = 0; r < rows; r += stride) keep[r] = 1;
  if (rows) keep[rows - 1] = 1;
  for (long r : frameRows)
    if (r >= 0) keep[std::size_t(r)] = 1;
  std::vector<long> kept(rows, -1);  // row -> index among the kept rows
  std::size_t count = 0;
  for (std::size_t r = 0; r < rows; ++r)
    if (keep[r]) kept[r] = long(count++);
  json series;
  series["names"] = s.names;
  series["rows"] = count;
  series["rowsInRun"] = rows;
  json columns = json::array();
  for (std::size_t c = 0; c < s.columns.size(); ++c) {
    std::vector<double> values;
    values.reserve(count);
    for (std::size_t r = 0; r < rows; ++r)
      if (keep[r]) values.push_back(s.columns[c][r]);
    columns.push_back(put("series" + std::to_string(c), values));
  }
  series["columns"] = std::move(columns);
  std::size_t i = 0;
  for (json& f : meta_["frames"]) {
    const long r = frameRows[i++];
    f["row"] = r >= 0 ? kept[std::size_t(r)] : -1;
    f["csvRow"] = r;  // the row in steps.csv (after its header)
  }
  meta_["series"] = std::move(series);
}

std::vector<std::size_t> chooseFrames(std::size_t count, double bytesPerFrame, std::size_t budget) {
  std::vector<std::size_t> chosen;
  if (count == 0) return chosen;
  // At most `fit` frames (two at least: the first and the last), evenly spaced from the first;
  // the last frame is always kept, in place of the one before it when there is no room.
  const double fitting = std::floor(double(budget) / std::max(bytesPerFrame, 1e-300));
  const std::size_t fit =
      std::max<std::size_t>(2, fitting >= double(count) ? count : std::size_t(fitting));
  if (fit >= count) {
    for (std::size_t i = 0; i < count; ++i) chosen.push_back(i);
    return chosen;
  }
  const std::size_t stride = (count - 1 + fit - 2) / (fit - 1);  // ceil((count - 1) / (fit - 1))
  for (std::size_t i = 0; i < count; i += stride) chosen.push_back(i);
  if (chosen.back() != count - 1) {
    if (chosen.size() >= fit) chosen.pop_back();
    chosen.push_back(count - 1);
  }
  return chosen;
}

std::string describeSize(std::size_t bytes) {
  char text[64];
  std::snprintf(text, sizeof text, "%.1f MB", double(bytes) / 1048576.0);
  return text;
}

std::string base64(const std::string& bytes) {
  static constexpr char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const std::uint32_t v = (std::uint32_t(std::uint8_t(bytes[i])) << 16) |
                            (std::uint32_t(std::uint8_t(bytes[i + 1])) << 8) |
                            std::uint8_t(bytes[i + 2]);
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += kAlphabet[v & 63];
  }
  if (i < bytes.size()) {
    std::uint32_t v = std::uint32_t(std::uint8_t(bytes[i])) << 16;
    if (i + 1 < bytes.size()) v |= std::uint32_t(std::uint8_t(bytes[i + 1])) << 8;
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += i + 1 < bytes.size() ? kAlphabet[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

namespace {

/// Text that cannot end the <script> element it is embedded in.
std::string scriptSafe(std::string text) {
  for (std::size_t at = 0; (at = text.find("</", at)) != std::string::npos; at += 3)
    text.replace(at, 2, "<\\/");
  return text;
}

/// JSON text inside a <script> element: every '<' as \u003c (valid JSON in strings, the only
/// place it can be), so that no "</script>", "<!--" or "<script" of a description or a path
/// can end the element or change how the page parses it.
std::string jsonInHtml(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    if (c == '<')
      out += "\\u003c";
    else
      out += c;
  }
  return out;
}

std::string htmlEscape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '&':
        out += "&amp;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

/// The "up" direction of the view: given, or the opposite of the run's gravity, or +z.
json upVector(const std::string& up, const json& info) {
  if (up == "auto") {
    if (info.contains("gravity") && info["gravity"].is_array() && info["gravity"].size() == 3) {
      double g[3], n = 0.0;
      for (int k = 0; k < 3; ++k) {
        g[k] = info["gravity"][std::size_t(k)].is_number()
                   ? info["gravity"][std::size_t(k)].get<double>()
                   : 0.0;
        n += g[k] * g[k];
      }
      if (n > 0.0 && std::isfinite(n))
        return json::array({-g[0] / std::sqrt(n), -g[1] / std::sqrt(n), -g[2] / std::sqrt(n)});
    }
    return json::array({0, 0, 1});
  }
  const double sign = up.size() == 2 && up[0] == '-' ? -1.0 : 1.0;
  const char axis = up.empty() ? ' ' : up.back();
  if ((up.size() == 1 || (up.size() == 2 && (up[0] == '-' || up[0] == '+'))) && axis >= 'x' &&
      axis <= 'z') {
    json v = json::array({0.0, 0.0, 0.0});
    v[std::size_t(axis - 'x')] = sign;
    return v;
  }
  throw InvalidInput("--up", "\"" + up + "\" is not an axis (x, y, z, -x, -y, -z or auto)");
}

}  // namespace

void writePlayerPage(std::ostream& out, const json& meta, const std::string& blob) {
  const std::string title =
      meta.contains("run") ? meta["run"].value("name", std::string("run")) : "run";
  out << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
         "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
         "<meta name=\"generator\" content=\"cutsim view\">\n"
      << "<title>" << htmlEscape(title) << " - cutsim</title>\n</head>\n<body>\n"
      << "<script type=\"application/json\" id=\"cutsim-meta\">" << jsonInHtml(meta.dump())
      << "</script>\n"
      << "<script type=\"application/octet-stream\" id=\"cutsim-data\">" << base64(blob)
      << "</script>\n"
      << "<script>" << scriptSafe(std::string(playerScript())) << "</script>\n</body>\n</html>\n";
}

PlayerReport writePlayer(const fs::path& runDir, const fs::path& html,
                         const PlayerOptions& options) {
  const RunFolder run = scanRun(runDir);
  PlayerReport report;
  report.framesInRun = run.surface.size();
  report.partial = run.partial;
  const json up = upVector(options.up, run.info);
  Series series;
  if (run.csv) series = readSeries(*run.csv);

  // The size of a frame, from the last one (usually the largest: cuts add points): its
  // positions and per-triangle fields, in base64; the arrays that change only with the topology
  // (triangles, borders, springs) are counted once in five frames.
  const Frame last = readFrame(run, run.surface.size() - 1);
  const double perFrame =
      4.0 / 3.0 *
      (4.0 * double(last.x.size() + 3 * last.strain.size() + last.obstacleX.size()) +
       0.2 * (4.0 * double(last.triangles.size() + last.borders.size() + last.springs.size()) +
              last.lips.size() + last.held.size()));
  const double fixedBytes =
      double(playerScript().size()) +
      4.0 / 3.0 * 8.0 * double(std::min(series.rows(), kMaxSeriesRows) * series.names.size()) +
      64.0 * double(run.surface.size()) + 65536.0;
  double budget = std::max(double(options.budgetBytes) - fixedBytes, 2.0 * perFrame);
  // The page, packed from the frames chosen by the estimate; packed again with fewer frames if
  // it came out above the budget (the estimate is of a typical frame, not of each).
  auto info = [&](const char* key) {
    return run.info.contains(key) && run.info[key].is_string() ? run.info[key].get<std::string>()
                                                               : std::string();
  };
  std::string name = info("scene");
  if (name.empty()) name = fs::absolute(runDir).lexically_normal().filename().string();
  if (name.empty()) name = "run";
  std::vector<std::size_t> chosen;
  std::string text;
  for (int attempt = 0;; ++attempt) {
    chosen = chooseFrames(run.surface.size(), perFrame, std::size_t(budget));
    FramePacker packer;
    for (std::size_t k = 0; k < chosen.size(); ++k) {
      packer.add(chosen[k] + 1 == run.surface.size() ? last : readFrame(run, chosen[k]));
      if (options.progress) options.progress(k + 1, chosen.size());
    }
    if (series.rows()) packer.setSeries(series);
    json meta = packer.meta();
    json runMeta;
    runMeta["name"] = name;
    runMeta["description"] = info("description");
    runMeta["partial"] = run.partial;
    runMeta["framesInRun"] = run.surface.size();
    runMeta["framesShown"] = chosen.size();
    runMeta["frameIndices"] = chosen;
    runMeta["up"] = up;
    runMeta["folder"] = runDir.string();
    meta["run"] = std::move(runMeta);
    if (!meta.contains("series"))
      meta["series"] = {{"names", json::array()}, {"rows", 0}, {"columns", json::array()}};
    std::ostringstream page;
    writePlayerPage(page, meta, packer.blob());
    text = page.str();
    // Over the budget with frames to spare: again, with the overshoot (and a tenth more) taken
    // from the frames' share (a few times at most).
    if (text.size() <= options.budgetBytes || chosen.size() <= 2 || attempt == 3) break;
    budget = std::max(0.0, budget - 1.1 * double(text.size() - options.budgetBytes));
  }
  report.framesShown = chosen.size();
  report.stride = chosen.size() >= 2 ? chosen[1] - chosen[0] : 1;
  report.bytes = text.size();
  core::writeFileAtomically(html, [&](std::ostream& o) { o << text; });
  return report;
}

}  // namespace cutsim::view

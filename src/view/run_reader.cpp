// Reads a run folder as `cutsim run` writes it (src/core/output/output.cpp): the ParaView
// collections
// (.pvd), their ASCII VTK PolyData frames (.vtp) and steps.csv. XML through pugixml; every error
// names the file, and the line where there is one.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <pugixml.hpp>
#include <sstream>

#include "cutsim/base/errors.hpp"
#include "cutsim/view/player.hpp"

namespace cutsim::view {

namespace fs = std::filesystem;

namespace {

std::string readWhole(const fs::path& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec))  // not a device or a folder that a forged name points to
    throw InvalidInput(path.string(), fs::exists(path, ec) ? "not a regular file" : "is missing");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InvalidInput(path.string(), "cannot be read");
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

/// "FILE:LINE" of a byte offset of a text.
std::string where(const fs::path& path, const std::string& text, std::ptrdiff_t offset) {
  offset = std::clamp<std::ptrdiff_t>(offset, 0, std::ptrdiff_t(text.size()));
  return path.string() + ":" +
         std::to_string(1 + std::count(text.begin(), text.begin() + offset, '\n'));
}

struct Xml {
  fs::path path;
  std::string text;
  pugi::xml_document doc;

  explicit Xml(const fs::path& p) : path(p), text(readWhole(p)) {
    const pugi::xml_parse_result r = doc.load_buffer(text.data(), text.size());
    if (!r)
      throw InvalidInput(where(path, text, r.offset),
                         std::string("not valid XML: ") + r.description());
  }
  std::string at(const pugi::xml_node& node) const {
    return where(path, text, node.offset_debug());
  }
};

std::vector<std::pair<double, std::string>> readPvd(const fs::path& path) {
  const Xml xml(path);
  const pugi::xml_node collection = xml.doc.child("VTKFile").child("Collection");
  if (!collection)
    throw InvalidInput(path.string(), "not a ParaView collection (no VTKFile/Collection)");
  std::vector<std::pair<double, std::string>> frames;
  for (const pugi::xml_node& d : collection.children("DataSet")) {
    const char* t = d.attribute("timestep").value();
    const std::string file = d.attribute("file").value();
    char* end = nullptr;
    const double time = std::strtod(t, &end);
    if (end == t || *end != '\0' || !std::isfinite(time))
      throw InvalidInput(xml.at(d), std::string("timestep \"") + t + "\" is not a finite number");
    if (file.empty() || file.find('/') != std::string::npos || file.find("..") != std::string::npos)
      throw InvalidInput(xml.at(d), "file \"" + file + "\" is not a frame file of this folder");
    if (!frames.empty() && time < frames.back().first)
      throw InvalidInput(xml.at(d),
                         "timestep " + std::string(t) + " is before the previous frame's");
    frames.emplace_back(time, file);
  }
  return frames;
}

template <typename T>
std::vector<T> numbers(const Xml& xml, const pugi::xml_node& array, std::size_t expected) {
  std::vector<T> out;
  const char* p = array.child_value();
  const char* end = p + std::strlen(p);
  // Every value takes two characters at least: a count beyond that is not in this file (and is
  // not reserved: a forged NumberOfPoints must not exhaust the memory).
  if (expected > std::size_t(end - p) / 2 + 1)
    throw InvalidInput(xml.at(array), std::string("DataArray ") + array.attribute("Name").value() +
                                          " should hold " + std::to_string(expected) +
                                          " values: more than its " + std::to_string(end - p) +
                                          " characters can");
  out.reserve(expected);
  while (true) {
    while (p < end && std::isspace(static_cast<unsigned char>(*p))) ++p;
    if (p >= end) break;
    // Read as double or as a wide integer, then checked to fit T (a flag beyond a byte, an index
    // beyond 32 bits, a value beyond single precision is an error, never wrapped or made infinite).
    std::conditional_t<std::is_floating_point_v<T>, double, long long> v{};
    const auto r = std::from_chars(p, end, v);
    bool fits = r.ec == std::errc();
    if constexpr (std::is_floating_point_v<T>)
      fits = fits && std::isfinite(v) && std::abs(v) <= double(std::numeric_limits<T>::max());
    else
      fits = fits && v >= 0 && static_cast<unsigned long long>(v) <= std::numeric_limits<T>::max();
    if (!fits) {
      // The whole number as written (a cut one, "7.96e+7" of "7.96e+70", would look fine).
      const char* q = p;
      while (q < end && q - p < 40 && !std::isspace(static_cast<unsigned char>(*q))) ++q;
      const bool cut = q < end && !std::isspace(static_cast<unsigned char>(*q));
      throw InvalidInput(xml.at(array),
                         std::string("DataArray ") + array.attribute("Name").value() + ": \"" +
                             std::string(p, q) + (cut ? "..." : "") + "\" is not " +
                             (std::is_floating_point_v<T> ? "a finite number (in single precision)"
                                                          : "an index or flag in range"));
    }
    out.push_back(T(v));
    p = r.ptr;
  }
  if (out.size() != expected)
    throw InvalidInput(xml.at(array), std::string("DataArray ") + array.attribute("Name").value() +
                                          " has " + std::to_string(out.size()) +
                                          " values, the piece needs " + std::to_string(expected));
  return out;
}

pugi::xml_node findArray(const pugi::xml_node& parent, const char* name) {
  for (const pugi::xml_node& a : parent.children("DataArray"))
    if (std::strcmp(a.attribute("Name").value(), name) == 0) return a;
  return {};
}

struct Piece {
  std::unique_ptr<Xml> xml;
  pugi::xml_node node;
  std::size_t points = 0, polys = 0, lines = 0;
};

Piece openPiece(const fs::path& path) {
  Piece p;
  p.xml = std::make_unique<Xml>(path);
  p.node = p.xml->doc.child("VTKFile").child("PolyData").child("Piece");
  if (!p.node)
    throw InvalidInput(path.string(), "not a VTK PolyData file (no VTKFile/PolyData/Piece)");
  p.points = p.node.attribute("NumberOfPoints").as_ullong();
  p.polys = p.node.attribute("NumberOfPolys").as_ullong();
  p.lines = p.node.attribute("NumberOfLines").as_ullong();
  // Counts no file of this size can hold (they would overflow the sizes computed from them).
  const std::size_t limit = p.xml->text.size();
  if (p.points > limit || p.polys > limit || p.lines > limit)
    throw InvalidInput(p.xml->at(p.node), "the piece's counts (" + std::to_string(p.points) +
                                              " points, " + std::to_string(p.polys) + " polys, " +
                                              std::to_string(p.lines) +
                                              " lines) are more than the file can hold");
  return p;
}

template <typename T>
std::vector<T> required(const Piece& p, const pugi::xml_node& parent, const char* name,
                        std::size_t count) {
  const pugi::xml_node a = findArray(parent, name);
  if (!a)
    throw InvalidInput(p.xml->at(parent ? parent : p.node),
                       std::string("no DataArray named ") + name);
  return numbers<T>(*p.xml, a, count);
}

std::vector<std::uint32_t> cells(const Piece& p, const char* block, std::size_t count,
                                 std::size_t per) {
  const pugi::xml_node b = p.node.child(block);
  if (count == 0) return {};
  auto c = required<std::uint32_t>(p, b, "connectivity", count * per);
  for (std::uint32_t i : c)
    if (i >= p.points)
      throw InvalidInput(p.xml->at(b), std::string(block) + ": point " + std::to_string(i) +
                                           " of " + std::to_string(p.points));
  return c;
}

/// The frame of `series` at the time of the surface's frame `index`, if it has one (found by
/// time, not by position: a collection with a frame less is matched right for the others).
std::optional<fs::path> companion(const RunFolder& run,
                                  const std::vector<std::pair<double, std::string>>& series,
                                  std::size_t index) {
  const double t = run.surface[index].first;
  if (index < series.size() && series[index].first == t) return run.dir / series[index].second;
  const auto it = std::lower_bound(
      series.begin(), series.end(), t,
      [](const std::pair<double, std::string>& f, double time) { return f.first < time; });
  if (it != series.end() && it->first == t) return run.dir / it->second;
  return std::nullopt;
}

}  // namespace

RunFolder scanRun(const fs::path& dir) {
  RunFolder run;
  run.dir = dir;
  std::error_code ec;
  if (!fs::exists(dir, ec)) throw InvalidInput(dir.string(), "no such folder");
  if (!fs::is_directory(dir, ec))
    throw InvalidInput(dir.string(),
                       "not a folder (give the folder a run wrote, cutsim run --out DIR)");
  fs::path surface = dir / "surface.pvd";
  if (!fs::exists(surface)) {
    surface = dir / "surface.partial.pvd";
    run.partial = true;
  }
  if (!fs::exists(surface)) {
    const bool csvOnly = fs::exists(dir / "steps.csv") || fs::exists(dir / "steps.partial.csv") ||
                         fs::exists(dir / ".steps.csv.tmp");
    throw InvalidInput(dir.string(),
                       csvOnly ? "the run wrote no frames (its scene's output has \"vtk\": false): "
                                 "nothing to play"
                               : "not a cutsim run folder (no surface.pvd or surface.partial.pvd)");
  }
  run.surface = readPvd(surface);
  if (run.surface.empty()) throw InvalidInput(surface.string(), "the collection lists no frames");
  const char* suffix = run.partial ? ".partial.pvd" : ".pvd";
  auto optional = [&](const char* name, std::vector<std::pair<double, std::string>>& out) {
    const fs::path p = dir / (std::string(name) + suffix);
    if (fs::exists(p)) out = readPvd(p);
  };
  optional("borders", run.borders);
  optional("springs", run.springs);
  optional("stitches", run.stitches);
  optional("obstacles", run.obstacles);
  optional("instruments", run.instruments);
  if (fs::exists(dir / "steps.csv"))
    run.csv = dir / "steps.csv";
  else if (fs::exists(dir / "steps.partial.csv"))  // a run stopped before its end
    run.csv = dir / "steps.partial.csv";
  else if (fs::exists(dir / ".steps.csv.tmp"))
    run.csv = dir / ".steps.csv.tmp";
  if (fs::exists(dir / "run.json")) {
    const std::string text = readWhole(dir / "run.json");
    run.info = nlohmann::json::parse(text, nullptr, false);
    if (run.info.is_discarded() || !run.info.is_object())
      throw InvalidInput((dir / "run.json").string(), "not a JSON object");
  }
  return run;
}

Frame readFrame(const RunFolder& run, std::size_t index) {
  Frame f;
  f.time = run.surface.at(index).first;
  {
    const Piece p = openPiece(run.dir / run.surface[index].second);
    const pugi::xml_node pd = p.node.child("PointData"), cd = p.node.child("CellData");
    f.x = required<float>(p, p.node.child("Points"), "position", 3 * p.points);
    if (findArray(pd, "rest_position"))
      f.rest = required<float>(p, pd, "rest_position", 3 * p.points);
    if (findArray(pd, "velocity")) f.v = required<float>(p, pd, "velocity", 3 * p.points);
    if (findArray(pd, "constraint")) f.held = required<std::uint8_t>(p, pd, "constraint", p.points);
    f.triangles = cells(p, "Polys", p.polys, 3);
    if (findArray(cd, "strain")) f.strain = required<float>(p, cd, "strain", p.polys);
    if (f.strain.empty()) f.strain.assign(p.polys, 0.0f);
  }
  const std::size_t points = f.x.size() / 3;
  auto lines = [&](const fs::path& path, std::vector<std::uint32_t>& out,
                   std::vector<std::uint8_t>* flags) {
    const Piece p = openPiece(path);
    if (p.points != points)
      throw InvalidInput(path.string(), "has " + std::to_string(p.points) +
                                            " points, its surface frame " + std::to_string(points));
    out = cells(p, "Lines", p.lines, 2);
    if (flags && p.lines)
      *flags = required<std::uint8_t>(p, p.node.child("CellData"), "lip", p.lines);
  };
  if (auto b = companion(run, run.borders, index)) {
    lines(*b, f.borders, &f.lips);
    f.hasBorders = true;
  }
  if (auto s = companion(run, run.springs, index)) lines(*s, f.springs, nullptr);
  if (auto s = companion(run, run.stitches, index)) lines(*s, f.stitches, nullptr);
  if (auto o = companion(run, run.obstacles, index)) {
    const Piece p = openPiece(*o);
    f.obstacleX = required<float>(p, p.node.child("Points"), "position", 3 * p.points);
    f.obstacleTriangles = cells(p, "Polys", p.polys, 3);
  }
  if (auto i = companion(run, run.instruments, index)) {
    const Piece p = openPiece(*i);
    f.instrumentX = required<float>(p, p.node.child("Points"), "position", 3 * p.points);
    // Segments as written (two points each): an odd count is not ours.
    if (p.points % 2 != 0)
      throw InvalidInput(i->string(), "has " + std::to_string(p.points) +
                                          " points, not two per instrument segment");
  }
  return f;
}

Series readSeries(const fs::path& csv) {
  std::ifstream in(csv, std::ios::binary);
  if (!in) throw InvalidInput(csv.string(), "cannot be read");
  Series s;
  std::string line;
  if (!std::getline(in, line)) return s;
  std::vector<std::string> header;
  {
    std::stringstream h(line);
    std::string name;
    while (std::getline(h, name, ',')) header.push_back(name);
  }
  std::vector<std::vector<double>> columns(header.size());
  std::vector<bool> numeric(header.size(), false);  // a number in one row at least
  std::size_t lineNo = 1;
  std::string cell;
  while (std::getline(in, line)) {
    ++lineNo;
    if (line.empty()) continue;
    std::size_t c = 0, start = 0;
    std::vector<double> row;
    while (start <= line.size()) {
      const std::size_t comma = std::min(line.find(',', start), line.size());
      const char* b = line.data() + start;
      const char* e = line.data() + comma;
      double v = 0.0;
      const auto r = std::from_chars(b, e, v);
      row.push_back(r.ec == std::errc() && r.ptr == e ? v : std::nan(""));
      ++c;
      start = comma + 1;
    }
    // A last line cut short by a run that was stopped while writing it is left out.
    if (row.size() != header.size()) {
      if (in.peek() == EOF) break;
      throw InvalidInput(
          csv.string() + ":" + std::to_string(lineNo),
          std::to_string(row.size()) + " columns, the header has " + std::to_string(header.size()));
    }
    for (std::size_t k = 0; k < row.size(); ++k) {
      if (!std::isnan(row[k])) numeric[k] = true;
      columns[k].push_back(row[k]);
    }
  }
  for (std::size_t k = 0; k < header.size(); ++k) {
    if (!numeric[k]) continue;
    s.names.push_back(header[k]);
    s.columns.push_back(std::move(columns[k]));
  }
  return s;
}

}  // namespace cutsim::view

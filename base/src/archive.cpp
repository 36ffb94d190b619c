// The checkpoints' binary archive (see archive.hpp).
#include "cutsim/base/archive.hpp"

#include <fcntl.h>
#include <unistd.h>
#include <zlib.h>

#include <bit>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

namespace cutsim {

std::uint32_t crc32Of(std::uint32_t crc, const void* data, std::size_t n) {
  uLong c = crc;
  const auto* bytes = static_cast<const Bytef*>(data);
  while (n > 0) {  // zlib takes lengths as uInt
    const uInt chunk = uInt(std::min<std::size_t>(n, 1u << 30));
    c = crc32(c, bytes, chunk);
    bytes += chunk;
    n -= chunk;
  }
  return std::uint32_t(c);
}

std::optional<std::uint32_t> fileCrc32(const std::filesystem::path& file, std::uint64_t n) {
  std::ifstream f(file, std::ios::binary);
  if (!f) return std::nullopt;
  std::uint32_t c = 0;
  std::vector<char> buffer(1 << 16);
  std::uint64_t left = n;
  while (left > 0) {
    f.read(buffer.data(), std::streamsize(std::min<std::uint64_t>(buffer.size(), left)));
    const std::streamsize got = f.gcount();
    if (got <= 0) break;
    c = crc32Of(c, buffer.data(), std::size_t(got));
    left -= std::uint64_t(got);
  }
  if (n != ~std::uint64_t(0) && left > 0) return std::nullopt;
  return c;
}

namespace {
constexpr char kMagic[8] = {'C', 'U', 'T', 'S', 'I', 'M', 'C', 'K'};
constexpr std::uint32_t kByteOrder = 0x01020304u;
static_assert(std::endian::native == std::endian::little, "archives are written little-endian");

std::uint32_t crc(const char* data, std::size_t n) {
  return crc32Of(0, data, n);
}

template <class T>
void put(std::string& out, T v) {
  out.append(reinterpret_cast<const char*>(&v), sizeof v);
}
}  // namespace

// ---- writer ----

void ArchiveWriter::begin(std::string_view tag) {
  if (!tag_.empty()) end();
  if (tag.empty() || tag.size() > 8)
    throw Error("archive: a section tag has 1 to 8 bytes: '" + std::string(tag) + "'");
  for (const auto& t : tags_)
    if (t == tag) throw Error("archive: section '" + std::string(tag) + "' written twice");
  tag_ = std::string(tag);
  tags_.push_back(tag_);
  section_.clear();
}

void ArchiveWriter::raw(const void* data, std::size_t n) {
  if (tag_.empty()) throw Error("archive: a value written outside any section");
  if (n == 0) return;  // (an empty array's data() may be null)
  section_.append(static_cast<const char*>(data), n);
}

void ArchiveWriter::str(std::string_view s) {
  u64(s.size());
  raw(s.data(), s.size());
}

void ArchiveWriter::f64s(std::span<const double> v) {
  u64(v.size());
  raw(v.data(), v.size() * sizeof(double));
}

void ArchiveWriter::u32s(std::span<const std::uint32_t> v) {
  u64(v.size());
  raw(v.data(), v.size() * sizeof(std::uint32_t));
}

void ArchiveWriter::end() {
  char tag[8] = {};
  std::memcpy(tag, tag_.data(), tag_.size());
  out_.append(tag, 8);
  put<std::uint64_t>(out_, section_.size());
  out_ += section_;
  put<std::uint32_t>(out_, crc(section_.data(), section_.size()));
  tag_.clear();
  section_.clear();
}

void ArchiveWriter::save(const std::filesystem::path& path) {
  if (!tag_.empty()) end();
  begin("END");
  end();
  std::string file(kMagic, 8);
  put<std::uint32_t>(file, kArchiveFormat);
  put<std::uint32_t>(file, kByteOrder);
  file += out_;
  // A temporary file beside the target, flushed to the disk, then renamed over it: a checkpoint
  // is either the old one or the new one, whole.
  std::string name = ".";  // appended, not "." + ...: GCC 12 warns (-Wrestrict) on that falsely
  name += path.filename().string();
  name += ".tmp";
  const std::filesystem::path tmp = path.parent_path() / name;
  if (path.filename().empty()) throw Error("archive: no file name in " + path.string());
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw Error("cannot write " + tmp.string() + ": " + std::strerror(errno));
  std::size_t done = 0;
  while (done < file.size()) {
    const ssize_t n = ::write(fd, file.data() + done, file.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const std::string why = std::strerror(errno);
      ::close(fd);
      ::unlink(tmp.c_str());
      throw Error("cannot write " + tmp.string() + ": " + why);
    }
    done += std::size_t(n);
  }
  const bool synced = ::fsync(fd) == 0;
  const int syncErrno = errno;
  const bool closed = ::close(fd) == 0;
  if (!synced || !closed) {
    const std::string why = std::strerror(synced ? errno : syncErrno);
    ::unlink(tmp.c_str());
    throw Error("cannot write " + tmp.string() + ": " + why);
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    ::unlink(tmp.c_str());
    throw Error("cannot rename " + tmp.string() + " to " + path.string() + ": " + ec.message());
  }
  // The rename itself reaches the disk with the folder's entry.
  const std::filesystem::path folder = path.parent_path().empty() ? "." : path.parent_path();
  const int dir = ::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir >= 0) {
    ::fsync(dir);
    ::close(dir);
  }
}

// ---- reader ----

ArchiveReader::ArchiveReader(const std::filesystem::path& path) : path_(path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) fail("is a folder, not a checkpoint");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InvalidInput(path.string(), "cannot open the checkpoint");
  if (!std::filesystem::is_regular_file(path, ec)) fail("not a regular file, not a checkpoint");
  // The magic first: a file that is not a checkpoint is not read whole.
  char magic[8] = {};
  if (!in.read(magic, 8) || std::memcmp(magic, kMagic, 8) != 0)
    fail("not a cutsim checkpoint (no CUTSIMCK header)");
  in.seekg(0);
  std::ostringstream buffer;
  buffer << in.rdbuf();
  data_ = buffer.str();
  if (data_.size() < 16 || std::memcmp(data_.data(), kMagic, 8) != 0)
    fail("not a cutsim checkpoint (no CUTSIMCK header)");
  std::uint32_t format = 0, order = 0;
  std::memcpy(&format, data_.data() + 8, 4);
  std::memcpy(&order, data_.data() + 12, 4);
  if (order != kByteOrder) fail("written on a machine of another byte order");
  if (format != kArchiveFormat)
    fail("checkpoint format " + std::to_string(format) + ", this cutsim reads format " +
         std::to_string(kArchiveFormat));
  std::size_t at = 16;
  bool ended = false;
  while (at < data_.size()) {
    if (data_.size() - at < 16) fail("ends inside a section header (the file is truncated)");
    std::string tag(data_.data() + at, 8);
    tag.erase(tag.find_last_not_of('\0') + 1);
    std::uint64_t length = 0;
    std::memcpy(&length, data_.data() + at + 8, 8);
    at += 16;
    if (length > data_.size() - at || data_.size() - at - length < 4)
      fail("ends inside section '" + tag + "' (the file is truncated)");
    std::uint32_t stored = 0;
    std::memcpy(&stored, data_.data() + at + length, 4);
    if (stored != crc(data_.data() + at, length))
      fail("section '" + tag + "' fails its checksum (the file is damaged)");
    if (tag == "END") {
      ended = true;
      at += length + 4;
      break;
    }
    if (!sections_.emplace(tag, std::make_pair(at, std::size_t(length))).second)
      fail("section '" + tag + "' appears twice");
    at += length + 4;
  }
  if (!ended) fail("has no end mark (the file is truncated)");
  if (at != data_.size()) fail("holds data after its end mark");
}

void ArchiveReader::fail(const std::string& message) const {
  throw InvalidInput(path_.string(), tag_.empty() ? message : "section '" + tag_ + "': " + message);
}

void ArchiveReader::open(std::string_view tag) {
  tag_.clear();
  auto it = sections_.find(std::string(tag));
  if (it == sections_.end()) fail("has no section '" + std::string(tag) + "'");
  tag_ = std::string(tag);
  pos_ = it->second.first;
  end_ = pos_ + it->second.second;
}

void ArchiveReader::close() {
  if (pos_ != end_)
    fail(std::to_string(end_ - pos_) + " bytes left unread (not what this cutsim writes)");
  tag_.clear();
}

void ArchiveReader::raw(void* data, std::size_t n) {
  if (tag_.empty()) fail("a value read outside any section");
  if (n > end_ - pos_) fail("a value runs past the section's end");
  if (n == 0) return;  // (an empty array's data() may be null)
  std::memcpy(data, data_.data() + pos_, n);
  pos_ += n;
}

std::uint64_t ArchiveReader::u64() {
  std::uint64_t v = 0;
  raw(&v, sizeof v);
  return v;
}
std::int64_t ArchiveReader::i64() {
  std::int64_t v = 0;
  raw(&v, sizeof v);
  return v;
}
double ArchiveReader::f64() {
  double v = 0;
  raw(&v, sizeof v);
  return v;
}
bool ArchiveReader::boolean() {
  const std::uint64_t v = u64();
  if (v > 1) fail("a flag holds " + std::to_string(v));
  return v == 1;
}

std::string ArchiveReader::str() {
  const std::uint64_t n = u64();
  if (n > end_ - pos_) fail("a string runs past the section's end");
  std::string s(data_.data() + pos_, n);
  pos_ += n;
  return s;
}

std::vector<double> ArchiveReader::f64s() {
  const std::uint64_t n = u64();
  if (n > (end_ - pos_) / sizeof(double)) fail("an array runs past the section's end");
  std::vector<double> v(n);
  raw(v.data(), n * sizeof(double));
  return v;
}

std::vector<std::uint32_t> ArchiveReader::u32s() {
  const std::uint64_t n = u64();
  if (n > (end_ - pos_) / sizeof(std::uint32_t)) fail("an array runs past the section's end");
  std::vector<std::uint32_t> v(n);
  raw(v.data(), n * sizeof(std::uint32_t));
  return v;
}

}  // namespace cutsim

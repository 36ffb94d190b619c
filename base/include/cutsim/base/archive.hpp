#pragma once
// The binary archive of checkpoints: a file of named sections, each with its length and CRC-32,
// behind a magic string and a format version, written atomically (a temporary file, flushed to
// disk, renamed into place). Values are stored as the machine holds them (little-endian
// IEEE doubles: the reader refuses a file from a machine of the other byte order), so that a
// double read back is the same bits.
//
//   "CUTSIMCK"  u32 format version  u32 0x01020304 (byte order)
//   per section: 8-byte tag (name padded with NULs), u64 payload length, payload, u32 CRC-32
//   the section "END" (empty) last
//
// A reader refuses, naming the file and what is wrong: a file that is not an archive, one of
// another format version or byte order, a section whose checksum fails, a file that ends inside a
// section, a missing section, a value read past its section's end, a section not read to its end.
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "cutsim/base/errors.hpp"

namespace cutsim {

/// 2: contact pairs carry their share of the law and their edges (flat-on-flat contact).
inline constexpr std::uint32_t kArchiveFormat = 2;

/// zlib's CRC-32 of n bytes, continuing from `crc` (0 to start): the archive's sections' checksum,
/// also what ties a run's files to its checkpoint.
std::uint32_t crc32Of(std::uint32_t crc, const void* data, std::size_t n);
/// The CRC-32 of the first n bytes of a file (all of it by default); nothing if the file is
/// shorter or cannot be read.
std::optional<std::uint32_t> fileCrc32(const std::filesystem::path& file,
                                       std::uint64_t n = ~std::uint64_t(0));

/// Writes one section at a time; save() writes the whole file atomically.
class ArchiveWriter {
 public:
  /// Starts a section (at most 8 bytes of name; each name once).
  void begin(std::string_view tag);
  void u64(std::uint64_t v) { raw(&v, sizeof v); }
  void i64(std::int64_t v) { raw(&v, sizeof v); }
  void f64(double v) { raw(&v, sizeof v); }
  void boolean(bool v) { u64(v ? 1 : 0); }
  void str(std::string_view s);
  void f64s(std::span<const double> v);
  void u32s(std::span<const std::uint32_t> v);
  void raw(const void* data, std::size_t n);
  /// Ends the last section and writes the file (a temporary file renamed into place).
  void save(const std::filesystem::path& path);

 private:
  void end();
  std::string out_;
  std::string section_;  // the open section's payload
  std::string tag_;
  std::vector<std::string> tags_;
};

/// Reads a whole archive (checks every section's checksum first), then one section at a time.
class ArchiveReader {
 public:
  explicit ArchiveReader(const std::filesystem::path& path);
  bool has(std::string_view tag) const { return sections_.count(std::string(tag)) > 0; }
  /// Opens a section for reading (throws if the archive has none of that name).
  void open(std::string_view tag);
  /// Throws unless the open section was read to its end.
  void close();
  std::uint64_t u64();
  std::int64_t i64();
  double f64();
  bool boolean();
  std::string str();
  std::vector<double> f64s();
  std::vector<std::uint32_t> u32s();
  void raw(void* data, std::size_t n);
  /// Bytes left in the open section.
  std::size_t remaining() const { return end_ - pos_; }
  /// Throws InvalidInput (where(): the archive's path) naming the open section and the problem.
  [[noreturn]] void fail(const std::string& message) const;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
  std::string data_;
  std::map<std::string, std::pair<std::size_t, std::size_t>> sections_;  // offset, length
  std::string tag_;
  std::size_t pos_ = 0, end_ = 0;
};

// ---- members declared once for both directions ----
//
// A checkpointed class lists its members once, in one function template used by both its save
// and its load (as libigl's serialisation does):
//
//   template <class Archive, class Self>
//   static void members(Archive& a, Self& self) { fields(a, self.time_, self.steps_); }
//   void save(ArchiveWriter& out) const { members(out, *this); }
//   void load(ArchiveReader& in) { members(in, *this); /* then check what was read */ }
//
// Each value is stored by its type: a floating-point number as f64, a signed integer as i64, an
// unsigned one as u64, a bool as a flag, a string as str, a vector of doubles as f64s.

template <class T>
void field(ArchiveWriter& out, const T& v) {
  if constexpr (std::is_same_v<T, bool>) {
    out.boolean(v);
  } else if constexpr (std::is_floating_point_v<T>) {
    out.f64(double(v));
  } else if constexpr (std::is_integral_v<T> && std::is_signed_v<T>) {
    out.i64(std::int64_t(v));
  } else if constexpr (std::is_integral_v<T>) {
    out.u64(std::uint64_t(v));
  } else if constexpr (std::is_same_v<T, std::string>) {
    out.str(v);
  } else {
    static_assert(std::is_same_v<T, std::vector<double>>,
                  "a member type the archive does not store");
    out.f64s(v);
  }
}

template <class T>
void field(ArchiveReader& in, T& v) {
  if constexpr (std::is_same_v<T, bool>) {
    v = in.boolean();
  } else if constexpr (std::is_floating_point_v<T>) {
    v = T(in.f64());
  } else if constexpr (std::is_integral_v<T> && std::is_signed_v<T>) {
    v = T(in.i64());
  } else if constexpr (std::is_integral_v<T>) {
    v = T(in.u64());
  } else if constexpr (std::is_same_v<T, std::string>) {
    v = in.str();
  } else {
    static_assert(std::is_same_v<T, std::vector<double>>,
                  "a member type the archive does not store");
    v = in.f64s();
  }
}

/// Writes the values in order (see above).
template <class... T>
void fields(ArchiveWriter& out, const T&... v) {
  (field(out, v), ...);
}
/// Reads them back in the same order.
template <class... T>
void fields(ArchiveReader& in, T&... v) {
  (field(in, v), ...);
}

}  // namespace cutsim

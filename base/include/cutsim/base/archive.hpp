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
#include <cstring>
#include <filesystem>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include "cutsim/base/errors.hpp"

namespace cutsim {

/// 2: contact pairs carry their share of the law and their edges (flat-on-flat contact).
/// 3: a grasp's path carries rotations about a pivot (forceps that turn).
/// 4: the solve summary counts the steps flagged residual-energy.
inline constexpr std::uint32_t kArchiveFormat = 4;

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
//   static void members(Archive& a, Self& self) {
//     fields(a, self.time_, self.steps_, slots(self.mass_.values(), "masses"));
//   }
//   void save(ArchiveWriter& out) const { members(out, *this); }
//   void load(ArchiveReader& in) { members(in, *this); /* then check what was read */ }
//
// Each value is stored by its type: a floating-point number as f64, a signed integer as i64, an
// unsigned one as u64, a bool as a flag, a string as str. A table (a std::vector, or an Eigen
// vector, of plain records: numbers, ids, structs of them, fixed-size Eigen vectors) is stored as
// its count (u64) and its bytes as the machine holds them; its reader refuses a count that runs
// past the section's end; a record's padding is written as zeros. slots() names a table of fixed
// size (one value per slot of the topology the reader has built): its reader refuses a count other
// than that size.

/// A record stored as its bytes: plain data with nothing to destroy (fixed-size Eigen vectors
/// qualify; their bytes are their values).
template <class T>
concept ArchiveRecord =
    std::is_standard_layout_v<T> && std::is_trivially_destructible_v<T> && !std::is_pointer_v<T>;

/// A resizable contiguous table of records (std::vector, Eigen's dynamic vectors).
template <class C>
concept ArchiveTable = !std::is_same_v<C, std::string> && requires(C & c) {
  c.data();
  c.size();
  c.resize(0);
  requires ArchiveRecord<std::remove_cv_t<std::remove_pointer_t<decltype(c.data())>>>;
};

/// A table of fixed size named for the reader's message (see slots()).
template <class T>
struct ArchiveSlots {
  std::span<T> values;
  std::string_view what;
};
/// The values of a table whose size the reader already knows (`what` names it in the message).
template <class T>
ArchiveSlots<T> slots(std::span<T> values, std::string_view what) {
  static_assert(ArchiveRecord<std::remove_cv_t<T>>, "a slot type the archive does not store");
  return {values, what};
}

namespace detail {
/// Writes n records as stored, with their padding (if they have any) written as zeros: a
/// checkpoint's bytes are a function of its values alone.
template <class R>
void writeRecords(ArchiveWriter& out, const R* records, std::size_t n) {
  using Plain = std::remove_cv_t<R>;
  if constexpr (std::is_arithmetic_v<Plain> || std::has_unique_object_representations_v<Plain> ||
                !std::is_trivially_copyable_v<Plain>) {
    // (A record that is not trivially copyable, one holding Eigen vectors, declares its padding
    // as zeroed members: the compiler cannot clear it.)
    out.raw(records, n * sizeof(Plain));
  } else {
    static_assert(__has_builtin(__builtin_clear_padding),
                  "a compiler that can clear a record's padding (GCC 11, Clang 16)");
    for (std::size_t i = 0; i < n; ++i) {
      alignas(Plain) unsigned char copy[sizeof(Plain)];
      std::memcpy(copy, static_cast<const void*>(records + i), sizeof(Plain));
      __builtin_clear_padding(reinterpret_cast<Plain*>(copy));
      out.raw(copy, sizeof(Plain));
    }
  }
}
}  // namespace detail

template <class T>
void field(ArchiveWriter& out, const ArchiveSlots<T>& s) {
  out.u64(s.values.size());
  detail::writeRecords(out, s.values.data(), s.values.size());
}

template <class T>
void field(ArchiveReader& in, const ArchiveSlots<T>& s) {
  static_assert(!std::is_const_v<T>, "slots() of a const table cannot be read into");
  const std::uint64_t n = in.u64();
  if (n != s.values.size())
    in.fail(std::string(s.what) + ": " + std::to_string(n) + " values saved, " +
            std::to_string(s.values.size()) + " slots in the topology");
  in.raw(s.values.data(), s.values.size() * sizeof(T));
}

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
    static_assert(ArchiveTable<T>, "a member type the archive does not store");
    out.u64(std::uint64_t(v.size()));
    detail::writeRecords(out, v.data(), std::size_t(v.size()));
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
    static_assert(ArchiveTable<T>, "a member type the archive does not store");
    using R = std::remove_cv_t<std::remove_pointer_t<decltype(v.data())>>;
    const std::uint64_t n = in.u64();
    if (n > in.remaining() / sizeof(R))
      in.fail("a table of " + std::to_string(n) + " records of " + std::to_string(sizeof(R)) +
              " bytes runs past the section's end");
    v.resize(static_cast<decltype(v.size())>(n));
    in.raw(v.data(), std::size_t(n) * sizeof(R));
  }
}

/// Writes the values in order (see above).
template <class... T>
void fields(ArchiveWriter& out, const T&... v) {
  (field(out, v), ...);
}
/// Reads them back in the same order (members, and the slots() of fixed tables).
template <class... T>
void fields(ArchiveReader& in, T&&... v) {
  (field(in, std::forward<T>(v)), ...);
}

}  // namespace cutsim

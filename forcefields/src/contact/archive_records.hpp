#pragma once
// Private to the contact code: its checkpoints' values written as stored. The contact's records
// (pairs, boxes, BVH nodes, cached pairs) hold plain numbers and fixed-size Eigen vectors only:
// their bytes are their values (Eigen's fixed-size vectors are plain arrays of doubles).
#include <cstdint>
#include <string>
#include <type_traits>
#include <vector>

#include "cutsim/base/archive.hpp"

namespace cutsim::forcefields::contact {

template <class T>
void saveRecords(ArchiveWriter& out, const std::vector<T>& v) {
  static_assert(std::is_standard_layout_v<T> && std::is_trivially_destructible_v<T>);
  out.u64(v.size());
  out.raw(v.data(), v.size() * sizeof(T));
}

template <class T>
void loadRecords(ArchiveReader& in, std::vector<T>& v, const char* what) {
  static_assert(std::is_standard_layout_v<T> && std::is_trivially_destructible_v<T>);
  const std::uint64_t n = in.u64();
  if (n > in.remaining() / sizeof(T))
    in.fail(std::string("contact: ") + what + ": a count of " + std::to_string(n));
  v.resize(n);
  in.raw(v.data(), n * sizeof(T));
}

}  // namespace cutsim::forcefields::contact

#pragma once
// Helpers of the checkpoints' readers and writers in the core (cutsim/base/archive.hpp): a
// table of trivially copyable values saved as stored, and read back only into a table of the
// same size (the one a component built on the checkpoint's topology).
#include <Eigen/Core>
#include <cstdint>
#include <span>
#include <string>
#include <type_traits>
#include <vector>

#include "cutsim/base/archive.hpp"

namespace cutsim::core::checkpoint {

template <class T>
void saveValues(ArchiveWriter& out, std::span<const T> values) {
  static_assert(std::is_trivially_copyable_v<T>);
  out.u64(values.size());
  out.raw(values.data(), values.size() * sizeof(T));
}

template <class T>
void loadValues(ArchiveReader& in, std::span<T> into, const std::string& what) {
  static_assert(std::is_trivially_copyable_v<T>);
  const std::uint64_t n = in.u64();
  if (n != into.size())
    in.fail(what + ": " + std::to_string(n) + " values saved, " + std::to_string(into.size()) +
            " slots in the topology");
  in.raw(into.data(), into.size() * sizeof(T));
}

/// A vector of any length (a warm start, a previous step), as stored.
inline void saveVector(ArchiveWriter& out, const Eigen::VectorXd& v) {
  out.f64s(std::span<const double>(v.data(), std::size_t(v.size())));
}
inline Eigen::VectorXd loadVector(ArchiveReader& in) {
  const std::vector<double> a = in.f64s();
  return Eigen::Map<const Eigen::VectorXd>(a.data(), Eigen::Index(a.size()));
}

}  // namespace cutsim::core::checkpoint

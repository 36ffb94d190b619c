#pragma once
// Private to the contact wing: its loops over many pairs or triangles in contiguous runs, each
// a task of oneTBB's scheduler (its pool of threads lives between calls), with results appended
// in the runs' order (the same, bit for bit, whatever the number of threads).
#include <algorithm>
#include <bit>
#include <cstdint>
#include <vector>

#include "cutsim/base/parallel.hpp"  // inParts

namespace cutsim::forcefields::contact {

/// run(begin, end, to) over [0, n) in `parts` contiguous runs (inParts), the first into `out`,
/// each other into a vector of its own in `scratch`, appended to `out` in the runs' order: what
/// one run over [0, n) into `out` appends.
template <class T, class Run>
void gatherInParts(std::size_t n, int parts, std::vector<std::vector<T>>& scratch,
                   std::vector<T>& out, Run&& run) {
  if (parts <= 1) {
    run(std::size_t(0), n, out);
    return;
  }
  scratch.resize(static_cast<std::size_t>(parts));
  const std::size_t before = out.size();
  try {
    inParts(n, parts, [&](int k, std::size_t begin, std::size_t end) {
      std::vector<T>& to = k == 0 ? out : scratch[std::size_t(k)];
      if (k > 0) to.clear();
      run(begin, end, to);
    });
  } catch (...) {
    out.resize(before);  // (as it was: nothing appended)
    throw;
  }
  for (std::size_t k = 1; k < scratch.size(); ++k)
    out.insert(out.end(), scratch[k].begin(), scratch[k].end());
}

/// Record indices, each once and ascending (what sorting them and dropping repeats gives), from
/// a bitset over the records: each(mark) marks them, then they are appended to `out`.
template <class Each>
void ascendingOnce(std::size_t records, std::vector<std::uint64_t>& bits,
                   std::vector<std::uint32_t>& out, Each&& each) {
  bits.assign((records + 63) / 64, 0);
  each([&](std::uint32_t i) { bits[i >> 6] |= std::uint64_t(1) << (i & 63); });
  out.clear();
  for (std::size_t w = 0; w < bits.size(); ++w)
    for (std::uint64_t b = bits[w]; b != 0; b &= b - 1)
      out.push_back(std::uint32_t(64 * w + std::size_t(std::countr_zero(b))));
}

/// The threads contact's loops use when its parameters leave it to the process: cutsim::threads()
/// (a scene's "threads", `cutsim run --threads N`, CUTSIM_THREADS, else the machine's hardware
/// threads).
int defaultThreads();

}  // namespace cutsim::forcefields::contact

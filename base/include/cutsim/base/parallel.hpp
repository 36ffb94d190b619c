#pragma once
// cutsim's parallel loops: contiguous runs of a range, each a task of oneTBB's scheduler (its
// pool of threads lives between calls). The runs depend on the number of parts asked for, never
// on how many threads the pool has; a loop whose parts write disjoint results, or whose results
// are combined in the parts' order, gives the same bits for any number of threads.
#include <cstddef>
#include <functional>

namespace cutsim {

/// Runs body(k, begin, end) for k in [0, parts) over contiguous runs that cover [0, n) in order
/// (run k: [n k / parts, n (k + 1) / parts)): the first on this thread, each other a task of
/// oneTBB's pool. Every run has ended before it returns; then the first exception a run threw
/// (in the runs' order) is thrown again. parts <= 1: body(0, 0, n) here.
void inParts(std::size_t n, int parts,
             const std::function<void(int k, std::size_t begin, std::size_t end)>& body);

/// The parts for a loop over n items: the thread setting (cutsim::threads()), fewer where a part
/// would have under minPerPart items (a task costs microseconds: below that the threads cost more
/// than they save); at least 1.
int partsFor(std::size_t n, std::size_t minPerPart);
/// The same with `threads` in place of the setting (a component with a thread count of its own).
int partsFor(std::size_t n, std::size_t minPerPart, int threads);

}  // namespace cutsim

// cutsim's parallel loops on oneTBB (parallel.hpp).
#include "cutsim/base/parallel.hpp"

#include <oneapi/tbb/task_group.h>

#include <algorithm>
#include <exception>
#include <vector>

#include "cutsim/base/threads.hpp"

namespace cutsim {

void inParts(std::size_t n, int parts,
             const std::function<void(int, std::size_t, std::size_t)>& body) {
  if (parts <= 1) {
    body(0, std::size_t(0), n);
    return;
  }
  std::vector<std::exception_ptr> failed(static_cast<std::size_t>(parts));
  auto run = [&](int k) {
    try {
      body(k, n * std::size_t(k) / std::size_t(parts), n * std::size_t(k + 1) / std::size_t(parts));
    } catch (...) {
      failed[std::size_t(k)] = std::current_exception();
    }
  };
  oneapi::tbb::task_group others;
  for (int k = 1; k < parts; ++k) others.run([&run, k] { run(k); });
  run(0);
  others.wait();
  for (const std::exception_ptr& e : failed)
    if (e) std::rethrow_exception(e);
}

int partsFor(std::size_t n, std::size_t minPerPart, int threads) {
  const std::size_t most = std::max<std::size_t>(1, n / std::max<std::size_t>(1, minPerPart));
  return int(std::min<std::size_t>(std::size_t(std::max(1, threads)), most));
}

int partsFor(std::size_t n, std::size_t minPerPart) {
  return partsFor(n, minPerPart, threads());
}

}  // namespace cutsim

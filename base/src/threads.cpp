// The process's thread setting (threads.hpp).
#include "cutsim/base/threads.hpp"

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <string>
#include <thread>

#include "cutsim/base/errors.hpp"

namespace cutsim {
namespace {
std::atomic<int> setting{0};
std::atomic<bool> overridden{false};
// CUTSIM_THREADS or the machine's hardware threads, read once (threads() is asked by every
// parallel loop, and the machine's count is read from a file).
std::atomic<int> fromEnvironment{0};

void check(int n) {
  if (n < 0 || n > 256)
    throw InvalidInput("threads",
                       "must be a whole number in [1, 256] (the threads parallel loops "
                       "may use), got " +
                           std::to_string(n));
}
}  // namespace

void setThreads(int n) {
  check(n);
  if (!overridden.load()) setting.store(n);
}

void overrideThreads(int n) {
  check(n);
  setting.store(n);
  overridden.store(n > 0);
}

int threads() {
  if (const int n = setting.load(); n > 0) return n;
  if (const int n = fromEnvironment.load(std::memory_order_relaxed); n > 0) return n;
  int n = 0;
  if (const char* s = std::getenv("CUTSIM_THREADS")) {
    char* end = nullptr;
    const long v = std::strtol(s, &end, 10);
    if (end == s || *end != '\0' || v < 1 || v > 256)
      throw InvalidInput(
          "CUTSIM_THREADS",
          "must be a whole number in [1, 256] (the threads parallel loops may use), got \"" +
              std::string(s) + "\"");
    n = int(v);
  } else {
    n = int(std::clamp<unsigned>(std::thread::hardware_concurrency(), 1, 256));
  }
  fromEnvironment.store(n, std::memory_order_relaxed);
  return n;
}

}  // namespace cutsim

// The contact wing's thread count (threads.hpp).
#include "threads.hpp"

#include <cstdlib>
#include <string>
#include <thread>

#include "cutsim/base/errors.hpp"

namespace cutsim::forcefields::contact {

/// The threads contact's loops use when its parameters leave it to the machine: CUTSIM_THREADS
/// when set (a whole number in [1, 256]; InvalidInput otherwise), else the machine's hardware
/// threads.
int defaultThreads() {
  if (const char* s = std::getenv("CUTSIM_THREADS")) {
    char* end = nullptr;
    const long v = std::strtol(s, &end, 10);
    if (end == s || *end != '\0' || v < 1 || v > 256)
      throw InvalidInput(
          "CUTSIM_THREADS",
          "must be a whole number in [1, 256] (the threads contact may use), got \"" +
              std::string(s) + "\"");
    return int(v);
  }
  return int(std::clamp<unsigned>(std::thread::hardware_concurrency(), 1, 256));
}

}  // namespace cutsim::forcefields::contact

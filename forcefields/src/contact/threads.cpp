// The contact wing's thread count (threads.hpp).
#include "threads.hpp"

#include "cutsim/base/threads.hpp"

namespace cutsim::forcefields::contact {

/// The threads contact's loops use when its parameters leave it to the process's setting
/// (cutsim::threads: a scene's "threads", `cutsim run --threads`, CUTSIM_THREADS, the machine).
int defaultThreads() {
  return cutsim::threads();
}

}  // namespace cutsim::forcefields::contact

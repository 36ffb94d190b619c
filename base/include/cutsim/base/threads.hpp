#pragma once
// How many threads cutsim's parallel loops may use (cutsim/base/parallel.hpp: the springs'
// passes, CG's vector work, contact's long loops): one setting for the process. Outputs never
// depend on it (docs/performance.md, "Threads"; docs/contact.md, "Detection").

namespace cutsim {

/// Sets the threads the parallel loops may use, in [1, 256] (InvalidInput otherwise); 0 goes
/// back to the default. A scene's "threads" sets it when its run is built (no effect while an
/// override holds).
void setThreads(int n);

/// The same, and scenes' settings no longer change it: `cutsim run --threads N`. 0 lifts it.
void overrideThreads(int n);

/// The setting: setThreads' value when one was given, else CUTSIM_THREADS when set (a whole
/// number in [1, 256]; InvalidInput otherwise), else the machine's hardware threads; these two
/// are read once per process, when first asked.
int threads();

}  // namespace cutsim

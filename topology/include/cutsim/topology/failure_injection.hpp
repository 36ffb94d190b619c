#pragma once
// Failure injection, for the tests and the soak run of the undo journal: every step of a topology
// operation that changes the mesh (a point made, a triangle detached or attached, a point left
// isolated removed, the commit's last step before its events) is a failure point. Armed with n,
// the n-th failure point passed from then on, on this thread, throws InjectedFailure. A failure
// there must leave the mesh exactly as before the operation and deliver no event (the undo
// journal; docs/topology-events.md, "Failures").
#include <cstdint>

#include "cutsim/base/errors.hpp"

namespace cutsim::topology {

/// Thrown at an armed failure point. A TopologyError: the operation is refused, nothing changed.
class InjectedFailure : public TopologyError {
 public:
  using TopologyError::TopologyError;
};

/// Arms the n-th failure point from now (n >= 1); 0 disarms. Resets the count of points passed.
void injectFailureAt(std::uint64_t n);
/// Failure points passed on this thread since the last injectFailureAt (armed or not).
std::uint64_t failurePointsPassed();
/// Marks a failure point named `where` (a string literal). Cheap when disarmed.
void failurePoint(const char* where);

}  // namespace cutsim::topology

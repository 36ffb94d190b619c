#pragma once
// The typed errors of cutsim. Every message names the element, the value or the place at fault.
#include <stdexcept>
#include <string>

namespace cutsim {

/// Base of every error cutsim throws on purpose.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Bad input from outside: a file, a parameter, a scene. `where()` is "PATH:LINE" (or "PATH", or
/// a parameter name) and `what()` is the full "PATH:LINE: message" line a user sees.
class InvalidInput : public Error {
 public:
  InvalidInput(std::string where, const std::string& message)
      : Error(where.empty() ? message : where + ": " + message),
        where_(std::move(where)),
        message_(message) {}
  const std::string& where() const noexcept { return where_; }
  const std::string& message() const noexcept { return message_; }

 private:
  std::string where_;
  std::string message_;
};

/// A topology request that cannot be carried out (an edge that does not exist, a path that is not
/// connected, a cut that leaves the surface). The mesh and every observer are left untouched.
class TopologyError : public Error {
 public:
  using Error::Error;
};

/// An observer threw while a transaction's events were delivered. The operation was carried out
/// (it cannot be undone once its events are out), every other observer received every event; the
/// observer named in the message may not follow the mesh any more (its validate() tells).
class ObserverError : public Error {
 public:
  using Error::Error;
};

/// A numerical failure of a solver (non-finite values, a factorisation that fails).
class SolverError : public Error {
 public:
  using Error::Error;
};

}  // namespace cutsim

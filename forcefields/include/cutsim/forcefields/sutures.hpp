#pragma once
// Sutures: stitches, each a thread tied between two points of the surface, that pull them
// together when stretched beyond its length and do nothing when slack (a thread does not push).
// The "suture" action places them where a needle pierces the surface and shortens them on a
// schedule (tightening); this field holds them, their forces and stiffness, and follows the
// topology: a stitch whose point is destroyed (carved away) goes; a cut that copies a stitched
// point leaves the stitch on the original; compaction renumbers them.
//
// A stitch (a, b, length L, stiffness k, damping c), d = x_a - x_b, l = |d|, n = d / l:
//   f_a = -k (l - L) n - c ((v_a - v_b) . n) n   when l > L (f_b = -f_a); nothing when l <= L
//   K_aa = -k [n n^T + (1 - L / l) (I - n n^T)], K_ab = -K_aa  (-K is positive semi-definite as
//   l > L); the damping's B_aa = -c n n^T (K leaves out the damping force's change with n)
//   energy k (l - L)^2 / 2 when l > L.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "cutsim/forcefields/force_field.hpp"
#include "cutsim/topology/topology.hpp"

namespace cutsim::forcefields {

struct SuturesParameters {
  double stiffness = 0.0;  ///< k of each stitch (N/m): finite, > 0
  double damping = 0.0;    ///< c of each stitch along its thread (N s/m): finite, >= 0
  /// Throws InvalidInput with where() = the parameter's name.
  void validate() const;
};

class Sutures final : public ForceField, public topology::TopologyObserver {
 public:
  struct Stitch {
    PointId a, b;
    double length = 0.0;     ///< the thread's length now (m)
    std::uint8_t alive = 1;  ///< 0 once one of its points is gone (1 byte: read back, checked)
  };

  Sutures(topology::Topology& topology, SuturesParameters parameters);
  Sutures(const Sutures&) = delete;
  Sutures& operator=(const Sutures&) = delete;
  ~Sutures() override;

  // ---- ForceField ----
  std::string typeName() const override { return "Sutures"; }
  void addForce(std::span<const double> x, std::span<const double> v,
                std::span<double> f) const override;
  void addDForce(std::span<const double> x, std::span<const double> dx, std::span<double> df,
                 double kFactor, double bFactor) const override;
  double potentialEnergy(std::span<const double> x) const override;
  /// The blocks of every live stitch, slack ones too (zero): the pattern does not change as a
  /// stitch tightens.
  void addKToMatrix(std::span<const double> x, MatrixAccumulator& m, double kFactor) const override;
  void addBToMatrix(std::span<const double> x, MatrixAccumulator& m, double bFactor) const override;
  void draw(std::vector<std::array<PointId, 2>>& segments) const override;
  /// New parameters between steps: the stitches stay.
  void continueFrom(const ForceField& previous) override;
  bool checkpointable() const override { return true; }
  void saveState(ArchiveWriter& out) const override;
  void loadState(ArchiveReader& in) override;

  // ---- TopologyObserver ----
  void onPointsDestroyed(const topology::Topology&, const topology::PointsDestroyed&) override;
  void onPointsRenumbered(const topology::Topology&, const topology::Renumbering&) override;
  std::string observerName() const override { return typeName(); }
  /// Every live stitch joins two live, distinct points with a finite length >= 0.
  void validate(const topology::Topology& topology,
                std::vector<std::string>& problems) const override;

  // ---- the stitches ----
  const SuturesParameters& parameters() const { return params_; }
  /// Ties a and b (live, distinct) with a thread of the given length; returns its index.
  std::size_t addStitch(PointId a, PointId b, double length);
  /// Sets a live stitch's length (>= 0, finite): what tightening does.
  void setLength(std::size_t stitch, double length);
  const std::vector<Stitch>& stitches() const { return stitches_; }
  std::size_t numLive() const;

 private:
  void checkSize(std::span<const double> a, const char* name, const char* what) const;

  topology::Topology* topology_;
  SuturesParameters params_;
  std::vector<Stitch> stitches_;
  topology::Subscription subscription_;
};

}  // namespace cutsim::forcefields

#pragma once
// Attachment: the surface tied to what lies beneath it (SOFA's RestShapeSpringsForceField is the
// reference), each point pulled towards its rest position by a zero-length spring whose stiffness
// and damping are given per unit of surface area, so that a refined or cut mesh holds as the
// coarse one did. Notes: docs/forcefields.md.
//
// Point p, with rest position X_p, area a_p (a third of the rest areas of its live triangles) and
// attached fraction w_p in [0, 1]:
//
//   k_p = w_p a_p k,   c_p = w_p a_p c      (k in N/m per m^2 of surface, c in N s/m per m^2),
//   f_p = -k_p (x_p - X_p) - c_p v_p,   E = sum_p 1/2 k_p |x_p - X_p|^2,
//   K block (p, p) = -k_p I,   B block (p, p) = -c_p I,
//
// exact (stiffnessIsExact), symmetric, negative semi-definite. A region (a box or a sphere in rest
// coordinates) limits the field to the points whose rest position lies in it: set tissue per
// region with one field per region. Points made later (a cut's copies, points on split edges, the
// repair's) take the attached fraction of the points they are made from (interpolated), so a cut
// through attached tissue stays attached on both lips; the areas follow every triangle event.
// Dissection releases points (w_p = 0): release() by a predicate on rest positions, as the
// "dissect" action does along a path or in a region.
#include <array>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "cutsim/forcefields/force_field.hpp"
#include "cutsim/topology/events.hpp"
#include "cutsim/topology/slot_data.hpp"
#include "cutsim/topology/topology.hpp"

namespace cutsim::forcefields {

/// The component's parameters.
struct AttachmentParameters {
  double stiffness = 0.0;  ///< k, N/m per m^2 of surface (N/m^3): finite, >= 0
  double damping = 0.0;    ///< c, N s/m per m^2 (N s/m^3): finite, >= 0
  /// The points attached (rest coordinates); none: every point.
  enum class Region { All, Box, Sphere };
  Region region = Region::All;
  Vec3 boxMin{0, 0, 0}, boxMax{0, 0, 0};
  Vec3 center{0, 0, 0};
  double radius = 0.0;

  /// Whether a rest position lies in the region (inclusive).
  bool contains(const Vec3& p) const;
  /// Throws cutsim::InvalidInput with where() = the parameter's name for a value out of range,
  /// NaN or infinite.
  void validate() const;
};

class Attachment final : public ForceField, public topology::TopologyObserver {
 public:
  /// Validates the parameters, attaches the live points in the region (w = 1, others 0) and
  /// subscribes to the topology, which must outlive this object's use.
  Attachment(topology::Topology& topology, AttachmentParameters parameters);
  Attachment(const Attachment&) = delete;
  Attachment& operator=(const Attachment&) = delete;
  ~Attachment() override;

  // ---- ForceField ----
  std::string typeName() const override { return "Attachment"; }
  void addForce(std::span<const double> x, std::span<const double> v,
                std::span<double> f) const override;
  void addDForce(std::span<const double> x, std::span<const double> dx, std::span<double> df,
                 double kFactor, double bFactor) const override;
  double potentialEnergy(std::span<const double> x) const override;
  /// One diagonal block per live point with area, released points included (the pattern depends
  /// on the topology only).
  void addKToMatrix(std::span<const double> x, MatrixAccumulator& m, double kFactor) const override;
  void addBToMatrix(std::span<const double> x, MatrixAccumulator& m, double bFactor) const override;
  /// New parameters between steps: the points `previous` released (a dissection) stay released;
  /// the new region decides the others (those it held keep their fraction).
  void continueFrom(const ForceField& previous) override;
  bool checkpointable() const override { return true; }
  void saveState(ArchiveWriter& out) const override;
  void loadState(ArchiveReader& in) override;

  // ---- TopologyObserver ----
  void onPointsCreated(const topology::Topology&, const topology::PointsCreated&) override;
  void onTrianglesCreated(const topology::Topology&, const topology::TrianglesCreated&) override;
  void onTrianglesDestroyed(const topology::Topology&,
                            const topology::TrianglesDestroyed&) override;
  void onTransactionEnd(const topology::Topology&, const topology::TransactionSummary&) override;
  std::string observerName() const override { return typeName(); }
  /// Areas and targets against a rebuild from the topology (1e-12 relative), fractions in [0, 1],
  /// dead slots at zero (fractions and areas).
  void validate(const topology::Topology& topology,
                std::vector<std::string>& problems) const override;

  // ---- the attachment ----
  const AttachmentParameters& parameters() const { return params_; }
  /// w_p: 1 attached, 0 released or outside the region, between for points made between both.
  double attached(PointId p) const { return weight_[p]; }
  /// a_p (m^2).
  double area(PointId p) const { return area_[p]; }
  /// The number of live points with w_p > 0.
  std::size_t numAttached() const;
  /// Releases (w_p = 0) the live points whose rest position `inside` accepts; returns how many
  /// were attached before.
  std::size_t release(const std::function<bool(const Vec3&)>& inside);
  /// Releases the live points `inside` accepts (by id: where they are now is the caller's to
  /// look up, as a cautery dissecting in the world does); returns how many were attached before.
  std::size_t releasePoints(const std::function<bool(PointId)>& inside);

 private:
  void recomputePoint(PointId p);
  /// perArea * w_p a_p I on every diagonal block of a point with area (K's and B's).
  void addDiagonal(MatrixAccumulator& m, double perArea) const;
  void checkSize(std::span<const double> a, const char* name, const char* what) const;

  topology::Topology* topology_;
  AttachmentParameters params_;
  topology::SlotData<PointId, double> weight_;  // w_p, interpolated into new points
  topology::SlotData<PointId, double> area_;    // a_p
  topology::SlotData<PointId, double, 3> target_;
  std::vector<PointId> touched_;  // points whose area or target changes in this transaction
  topology::Subscription subscription_;
};

/// The points of the live surface within `halfWidth` of a polyline (rest coordinates).
std::function<bool(const Vec3&)> nearPolyline(std::vector<Vec3> polyline, double halfWidth);

}  // namespace cutsim::forcefields

#include "cutsim/forcefields/sutures.hpp"

#include <cmath>
#include <stdexcept>

#include "cutsim/base/archive.hpp"
#include "cutsim/base/numbers.hpp"
#include "cutsim/forcefields/parameters.hpp"
#include "cutsim/forcefields/registry.hpp"

namespace cutsim::forcefields {
namespace {

struct Thread {
  Eigen::Vector3d n;  // unit, from b to a
  double l = 0.0;     // |x_a - x_b|
  bool taut = false;  // l > L
};

Thread threadOf(const Sutures::Stitch& s, std::span<const double> x) {
  Thread t;
  const Eigen::Vector3d d(x[3 * s.a.idx()] - x[3 * s.b.idx()],
                          x[3 * s.a.idx() + 1] - x[3 * s.b.idx() + 1],
                          x[3 * s.a.idx() + 2] - x[3 * s.b.idx() + 2]);
  t.l = d.norm();
  t.taut = t.l > s.length && t.l > 0.0;
  t.n = t.l > 0.0 ? Eigen::Vector3d(d / t.l) : Eigen::Vector3d::Zero();
  return t;
}

/// The stiffness block -K_aa = k [n n^T + (1 - L / l) (I - n n^T)] of a taut thread (zero if
/// slack).
Eigen::Matrix3d stiffnessBlock(const Sutures::Stitch& s, const Thread& t, double k) {
  if (!t.taut) return Eigen::Matrix3d::Zero();
  const Eigen::Matrix3d nn = t.n * t.n.transpose();
  return k * (nn + (1.0 - s.length / t.l) * (Eigen::Matrix3d::Identity() - nn));
}

Eigen::Vector3d at(std::span<const double> a, PointId p) {
  return {a[3 * p.idx()], a[3 * p.idx() + 1], a[3 * p.idx() + 2]};
}

void add(std::span<double> f, PointId p, const Eigen::Vector3d& v) {
  for (int c = 0; c < 3; ++c) f[3 * p.idx() + std::size_t(c)] += v[c];
}

}  // namespace

void SuturesParameters::validate() const {
  requireFinitePositive("stiffness", stiffness);
  requireFiniteNonNegative("damping", damping);
}

Sutures::Sutures(topology::Topology& topology, SuturesParameters parameters)
    : topology_(&topology), params_(parameters) {
  params_.validate();
  subscription_ = topology.subscribe(*this);
}

Sutures::~Sutures() = default;

void Sutures::checkSize(std::span<const double> a, const char* name, const char* what) const {
  const std::size_t need = 3 * static_cast<std::size_t>(topology_->pointCapacity());
  if (a.size() < need)
    throw std::invalid_argument(std::string("Sutures::") + what + ": " + name +
                                " must hold 3 * pointCapacity = " + std::to_string(need) +
                                " doubles, got " + std::to_string(a.size()));
}

std::size_t Sutures::addStitch(PointId a, PointId b, double length) {
  const auto live = [this](PointId p) {
    return p.idx() < topology_->pointCapacity() && topology_->isPointAlive(p);
  };
  if (!live(a) || !live(b) || a == b)
    throw std::invalid_argument("Sutures::addStitch: a stitch ties two distinct live points (got " +
                                std::to_string(a.idx()) + " and " + std::to_string(b.idx()) + ")");
  if (!(length >= 0) || !std::isfinite(length))
    throw std::invalid_argument("Sutures::addStitch: a thread's length must be finite and >= 0");
  stitches_.push_back({a, b, length, 1});
  return stitches_.size() - 1;
}

void Sutures::setLength(std::size_t stitch, double length) {
  if (stitch >= stitches_.size())
    throw std::invalid_argument("Sutures::setLength: no stitch " + std::to_string(stitch));
  if (!(length >= 0) || !std::isfinite(length))
    throw std::invalid_argument("Sutures::setLength: a thread's length must be finite and >= 0");
  stitches_[stitch].length = length;
}

std::size_t Sutures::numLive() const {
  std::size_t n = 0;
  for (const Stitch& s : stitches_) n += s.alive ? 1 : 0;
  return n;
}

void Sutures::addForce(std::span<const double> x, std::span<const double> v,
                       std::span<double> f) const {
  checkSize(x, "x", "addForce");
  checkSize(f, "f", "addForce");
  if (!v.empty()) checkSize(v, "v", "addForce");  // empty: at rest
  for (const Stitch& s : stitches_) {
    if (!s.alive) continue;
    const Thread t = threadOf(s, x);
    if (!t.taut) continue;
    Eigen::Vector3d fa = -params_.stiffness * (t.l - s.length) * t.n;
    if (!v.empty() && params_.damping > 0.0)
      fa -= params_.damping * (at(v, s.a) - at(v, s.b)).dot(t.n) * t.n;
    add(f, s.a, fa);
    add(f, s.b, -fa);
  }
}

void Sutures::addDForce(std::span<const double> x, std::span<const double> dx, std::span<double> df,
                        double kFactor, double bFactor) const {
  checkSize(x, "x", "addDForce");
  checkSize(dx, "dx", "addDForce");
  checkSize(df, "df", "addDForce");
  for (const Stitch& s : stitches_) {
    if (!s.alive) continue;
    const Thread t = threadOf(s, x);
    if (!t.taut) continue;
    const Eigen::Matrix3d block = kFactor * stiffnessBlock(s, t, params_.stiffness) +
                                  bFactor * params_.damping * t.n * t.n.transpose();
    const Eigen::Vector3d d = at(dx, s.a) - at(dx, s.b);
    add(df, s.a, -block * d);
    add(df, s.b, block * d);
  }
}

double Sutures::potentialEnergy(std::span<const double> x) const {
  checkSize(x, "x", "potentialEnergy");
  double e = 0.0;
  for (const Stitch& s : stitches_) {
    if (!s.alive) continue;
    const Thread t = threadOf(s, x);
    if (t.taut) e += 0.5 * params_.stiffness * (t.l - s.length) * (t.l - s.length);
  }
  return e;
}

void Sutures::addKToMatrix(std::span<const double> x, MatrixAccumulator& m, double kFactor) const {
  checkSize(x, "x", "addKToMatrix");
  for (const Stitch& s : stitches_) {
    if (!s.alive) continue;
    const Eigen::Matrix3d b = -kFactor * stiffnessBlock(s, threadOf(s, x), params_.stiffness);
    m.addBlock(s.a, s.a, b);
    m.addBlock(s.b, s.b, b);
    if (m.diagonalOnly()) continue;
    m.addBlock(s.a, s.b, -b);
    m.addBlock(s.b, s.a, -b);
  }
}

void Sutures::addBToMatrix(std::span<const double> x, MatrixAccumulator& m, double bFactor) const {
  checkSize(x, "x", "addBToMatrix");
  for (const Stitch& s : stitches_) {
    if (!s.alive) continue;
    const Thread t = threadOf(s, x);
    const Eigen::Matrix3d b =
        t.taut ? Eigen::Matrix3d(-bFactor * params_.damping * t.n * t.n.transpose())
               : Eigen::Matrix3d::Zero();
    m.addBlock(s.a, s.a, b);
    m.addBlock(s.b, s.b, b);
    if (m.diagonalOnly()) continue;
    m.addBlock(s.a, s.b, -b);
    m.addBlock(s.b, s.a, -b);
  }
}

void Sutures::draw(std::vector<std::array<PointId, 2>>& segments) const {
  for (const Stitch& s : stitches_)
    if (s.alive) segments.push_back({s.a, s.b});
}

void Sutures::continueFrom(const ForceField& previous) {
  const auto* old = dynamic_cast<const Sutures*>(&previous);
  if (old && old->topology_ == topology_) stitches_ = old->stitches_;
}

void Sutures::onPointsDestroyed(const topology::Topology&, const topology::PointsDestroyed& e) {
  for (PointId p : e.points)
    for (Stitch& s : stitches_)
      if (s.a == p || s.b == p) s.alive = 0;
}

void Sutures::onPointsRenumbered(const topology::Topology&, const topology::Renumbering& r) {
  for (Stitch& s : stitches_) {
    if (!s.alive) continue;
    s.a = PointId(r.oldToNew[s.a.idx()]);
    s.b = PointId(r.oldToNew[s.b.idx()]);
  }
}

void Sutures::validate(const topology::Topology& topology,
                       std::vector<std::string>& problems) const {
  for (std::size_t i = 0; i < stitches_.size(); ++i) {
    const Stitch& s = stitches_[i];
    if (s.alive > 1)
      problems.push_back("Sutures: stitch " + std::to_string(i) + " is neither live nor gone");
    if (!s.alive) continue;
    const auto live = [&](PointId p) {
      return p.idx() < topology.pointCapacity() && topology.isPointAlive(p);
    };
    if (!live(s.a) || !live(s.b) || s.a == s.b)
      problems.push_back("Sutures: stitch " + std::to_string(i) + " ties " +
                         std::to_string(s.a.idx()) + " and " + std::to_string(s.b.idx()) +
                         ", which are not two live points");
    if (!(s.length >= 0) || !std::isfinite(s.length))
      problems.push_back("Sutures: stitch " + std::to_string(i) + " has a length of " +
                         std::to_string(s.length));
  }
}

void Sutures::saveState(ArchiveWriter& out) const {
  fields(out, stitches_);
}

void Sutures::loadState(ArchiveReader& in) {
  fields(in, stitches_);
  std::vector<std::string> problems;
  validate(*topology_, problems);
  if (!problems.empty()) in.fail(problems.front());
}

namespace {
const bool registered = ForceFieldRegistry::instance().add(
    {"Sutures",
     "the stitches the \"suture\" action places: threads tied between two points of the surface "
     "that pull them together when stretched beyond their length (tightened on a schedule), "
     "slack otherwise",
     {{"stiffness", KeyType::Number, "of each stitch's thread (N/m), > 0", {}, true},
      {"damping", KeyType::Number, "along each thread (N s/m), >= 0 (default 0)"}},
     {},
     [](const ParameterSource& s) -> std::any {
       SuturesParameters p;
       s.require("stiffness");
       p.stiffness = s.number("stiffness");
       p.damping = s.nonNegative("damping", 0.0);
       s.check([&] { p.validate(); });
       return p;
     },
     [](const std::any& p, topology::Topology& t) -> std::unique_ptr<ForceField> {
       return std::make_unique<Sutures>(t, std::any_cast<const SuturesParameters&>(p));
     }});
}  // namespace

}  // namespace cutsim::forcefields

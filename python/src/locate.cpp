// World and material from Python: the nearest surface point to world points, ray and segment
// hits, and where material points are now (forcefields::SurfaceQuery over the deformed surface).
// Vectorised: one call for many points.
#include <limits>

#include "cutsim/forcefields/surface_query.hpp"
#include "simulation.hpp"

namespace cutsim::python {
namespace {

/// (n, 3) rows of finite numbers; a single [x, y, z] is one row.
std::vector<core::Vec3> readRows(const py::handle& obj, const char* what) {
  auto a = floats(obj);
  if (a && a.ndim() == 1 && a.shape(0) == 3) {
    core::Vec3 p{a.at(0), a.at(1), a.at(2)};
    for (int c = 0; c < 3; ++c)
      if (!std::isfinite(p[c])) throw py::value_error(std::string(what) + ": non-finite value");
    return {p};
  }
  return readVec3List(obj, what);
}

/// The arrays of n results, rows of zeros (triangle -1) where nothing was found.
struct Results {
  py::array_t<bool> found;
  py::array_t<std::int64_t> triangle;
  py::array_t<double> weights, point, rest, scalar;
  explicit Results(std::size_t n)
      : found(py::ssize_t(n)),
        triangle(py::ssize_t(n)),
        weights({n, std::size_t(3)}),
        point({n, std::size_t(3)}),
        rest({n, std::size_t(3)}),
        scalar(py::ssize_t(n)) {
    std::fill_n(found.mutable_data(), n, false);
    std::fill_n(triangle.mutable_data(), n, std::int64_t(-1));
    for (auto* a : {&weights, &point, &rest}) std::fill_n(a->mutable_data(), 3 * n, 0.0);
    std::fill_n(scalar.mutable_data(), n, 0.0);
  }
  void set(std::size_t i, const topology::Topology& topo, topology::TriangleId t,
           const std::array<double, 3>& w, const core::Vec3& p, double value) {
    found.mutable_data()[i] = true;
    triangle.mutable_data()[i] = std::int64_t(t.idx());
    const core::Vec3 r = topo.restPositionOn(t, w);
    for (std::size_t c = 0; c < 3; ++c) {
      weights.mutable_data()[3 * i + c] = w[c];
      point.mutable_data()[3 * i + c] = p[c];
      rest.mutable_data()[3 * i + c] = r[c];
    }
    scalar.mutable_data()[i] = value;
  }
  py::dict dict(const char* scalarName) const {
    py::dict d("found"_a = found, "triangle"_a = triangle, "weights"_a = weights, "point"_a = point,
               "rest"_a = rest);
    d[scalarName] = scalar;
    return d;
  }
};

}  // namespace

forcefields::SurfaceQuery& Simulation::surfaceQuery() {
  if (!query_)
    query_ = std::make_unique<forcefields::SurfaceQuery>(sim().topology(), sim().state().x());
  else
    query_->update(sim().state().x());
  return *query_;
}

py::dict Simulation::locate(const py::handle& points, double maxDistance) {
  requireReadable("locate");
  if (!(maxDistance > 0)) throw py::value_error("locate: max_distance must be > 0");
  const auto q = readRows(points, "locate: points");
  const auto hits = surfaceQuery().closestPoints(q, maxDistance);
  Results out(q.size());
  for (std::size_t i = 0; i < q.size(); ++i)
    if (const auto& hit = hits[i])
      out.set(i, sim().topology(), hit->triangle, hit->weights, hit->point, hit->distance);
  return out.dict("distance");
}

py::dict Simulation::rayHits(const py::handle& origins, const py::handle& directions, double maxT) {
  requireReadable("ray_hits");
  if (!(maxT > 0)) throw py::value_error("ray_hits: max_t must be > 0");
  const auto o = readRows(origins, "ray_hits: origins");
  auto d = readRows(directions, "ray_hits: directions");
  if (d.size() == 1 && o.size() > 1) d.assign(o.size(), d.front());
  if (d.size() != o.size())
    throw py::value_error("ray_hits: " + std::to_string(o.size()) + " origins and " +
                          std::to_string(d.size()) + " directions (give one, or one per origin)");
  for (std::size_t i = 0; i < d.size(); ++i)
    if (d[i][0] == 0 && d[i][1] == 0 && d[i][2] == 0)
      throw py::value_error("ray_hits: direction " + std::to_string(i) + " is zero");
  const auto& query = surfaceQuery();
  Results out(o.size());
  for (std::size_t i = 0; i < o.size(); ++i)
    if (const auto hit = query.rayHit(o[i], d[i], maxT))
      out.set(i, sim().topology(), hit->triangle, hit->weights, hit->point, hit->t);
  return out.dict("t");
}

py::dict Simulation::segmentHits(const py::handle& a, const py::handle& b) {
  requireReadable("segment_hits");
  const core::Vec3 p = readVec3(a, "segment_hits: a"), q = readVec3(b, "segment_hits: b");
  const auto hits = surfaceQuery().segmentHits(p, q);
  Results out(hits.size());
  for (std::size_t i = 0; i < hits.size(); ++i)
    out.set(i, sim().topology(), hits[i].triangle, hits[i].weights, hits[i].point, hits[i].t);
  py::dict d = out.dict("t");
  d.attr("pop")("found");
  return d;
}

py::array_t<double> Simulation::worldOf(const py::handle& triangles, const py::handle& weights,
                                        bool rest) {
  requireReadable(rest ? "rest_of" : "world_of");
  const char* what = rest ? "rest_of" : "world_of";
  py::array_t<std::int64_t, py::array::c_style | py::array::forcecast> t;
  try {
    t = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(triangles);
  } catch (const py::error_already_set&) {
  }
  if (!t || t.ndim() != 1)
    throw py::value_error(std::string(what) + ": triangles must be a list of triangle ids");
  const auto w = readRows(weights, (std::string(what) + ": weights").c_str());
  const std::size_t n = std::size_t(t.shape(0));
  if (w.size() != n)
    throw py::value_error(std::string(what) + ": " + std::to_string(n) + " triangles and " +
                          std::to_string(w.size()) + " rows of weights");
  const auto& topo = sim().topology();
  const auto x = sim().state().x();
  py::array_t<double> out({n, std::size_t(3)});
  for (std::size_t i = 0; i < n; ++i) {
    const std::int64_t id = t.at(py::ssize_t(i));
    if (id < 0 || id >= std::int64_t(topo.triangleCapacity()) ||
        !topo.isTriangleAlive(topology::TriangleId(Index(id))))
      throw py::value_error(std::string(what) + ": triangle " + std::to_string(id) + " (row " +
                            std::to_string(i) + ") does not exist");
    const std::array<double, 3> wi{w[i][0], w[i][1], w[i][2]};
    const auto tid = topology::TriangleId(Index(id));
    core::Vec3 p{0, 0, 0};
    if (rest) {
      p = topo.restPositionOn(tid, wi);
    } else {
      const auto v = topo.triangleVertices(tid);
      for (std::size_t k = 0; k < 3; ++k)
        for (std::size_t c = 0; c < 3; ++c) p[c] += wi[k] * x[3 * v[k].idx() + c];
    }
    for (std::size_t c = 0; c < 3; ++c) out.mutable_data()[3 * i + c] = p[c];
  }
  return out;
}

void bindLocate(SimulationClass& cls) {
  constexpr double inf = std::numeric_limits<double>::infinity();
  cls.def("locate", &Simulation::locate, "points"_a, "max_distance"_a = inf,
          "The nearest point of the surface as it is now to each world point ((n, 3), or one "
          "[x, y, z]): a dict of arrays, one row per point: found (bool: a surface point within "
          "max_distance), triangle (id, -1 where none), weights (barycentric, in the triangle's "
          "vertex order), point (world), rest (rest coordinates: where it is in the material), "
          "distance. Rows where nothing was found hold zeros.")
      .def("ray_hits", &Simulation::rayHits, "origins"_a, "directions"_a, "max_t"_a = inf,
           "The first surface point each ray meets (origins (n, 3); directions (n, 3) or one for "
           "all, not zero): found, triangle, weights, point, rest, and t, the distance along the "
           "unit direction.")
      .def("segment_hits", &Simulation::segmentHits, "a"_a, "b"_a,
           "Every surface point the segment a-b crosses, by t (the fraction from a): triangle, "
           "weights, point, rest, t.")
      .def(
          "world_of",
          [](Simulation& s, const py::handle& t, const py::handle& w) {
            return s.worldOf(t, w, false);
          },
          "triangles"_a, "weights"_a,
          "Where material points (triangle ids, barycentric weights (n, 3)) are now (n, 3).")
      .def(
          "rest_of",
          [](Simulation& s, const py::handle& t, const py::handle& w) {
            return s.worldOf(t, w, true);
          },
          "triangles"_a, "weights"_a, "Where material points are in rest coordinates (n, 3).");
}

}  // namespace cutsim::python

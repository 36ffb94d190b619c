#pragma once
// Ids from integer literals, for the tests' small meshes (in namespace cutsim: every test finds it)
// (ids never convert implicitly: cutsim/topology/types.hpp).
#include "cutsim/topology/types.hpp"

namespace cutsim {

/// The triangle of points a, b, c.
inline topology::TriangleVertices tri(topology::Index a, topology::Index b, topology::Index c) {
  return {topology::PointId(a), topology::PointId(b), topology::PointId(c)};
}

}  // namespace cutsim

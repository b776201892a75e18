// Helpers shared by the surface tests.
#pragma once
#include "shapemap/eval/surface_distortion.h"
#include "shapemap/maps.h"
#include "shapemap/mesh.h"

namespace shapemap::testing {

// Flipped plus collapsed triangles of the map P of S onto T (the fold count the tests bound).
inline int bad(const TriMesh& S, const TriMesh& T, const BarycentricMap& P) {
  const SurfaceDistortion d = surface_distortion(S, T, P);
  return d.flipped + d.degenerate;
}

}  // namespace shapemap::testing

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

// The identity map of a mesh onto itself (each vertex at its corner of its last face).
inline BarycentricMap identity_map(const TriMesh& M) {
  BarycentricMap m;
  m.elem.resize(M.num_vertices());
  m.bary.setZero(M.num_vertices(), 3);
  for (int f = 0; f < M.num_faces(); ++f)
    for (int j = 0; j < 3; ++j) {
      m.elem(M.F(f, j)) = f;
      m.bary.row(M.F(f, j)).setZero();
      m.bary(M.F(f, j), j) = 1.0;
    }
  return m;
}

}  // namespace shapemap::testing

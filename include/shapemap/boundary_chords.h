// Boundary chords of a tet mesh: interior edges whose two endpoints both lie on the
// boundary. A map that sends the boundary onto a sphere (ball parameterization) must
// send such an edge to a chord of the sphere, and a tet whose four vertices are all on
// the boundary to a tet inscribed in the sphere, whose volume is O(h^4) for spherical
// edge length h instead of O(h^3): it is squeezed flat (D_V near 1) or folds. Splitting
// every chord at its midpoint gives each such tet an interior vertex
// (docs/methods.md, "Boundary chords").
#pragma once
#include "shapemap/mesh.h"
#include <array>
#include <vector>

namespace shapemap {

// The chords of T (each once, smaller vertex index first, sorted).
std::vector<std::array<int, 2>> boundary_chords(const TetMesh& mesh);

// Tets whose four vertices all lie on the boundary.
int boundary_only_tets(const TetMesh& mesh);

// Splits every chord at its midpoint: each tet around the chord becomes two (one vertex
// of the chord replaced by the midpoint, so orientation is kept and the volume halved).
// The boundary faces and the positions of old vertices are unchanged; new vertices are
// appended. Afterwards no chord is left (the new edges all end at an interior vertex), and
// only tets with three boundary faces can still have all four vertices on the boundary.
// Returns the number of chords split.
int split_boundary_chords(TetMesh& mesh);

}  // namespace shapemap

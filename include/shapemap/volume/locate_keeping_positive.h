// The volume map's landing (ours, issue 19) keeps the map files equal to X: after each of its
// moves (boundary images back to the target's boundary, the reconciliation of the two
// boundaries, the interiors relaxed last at alpha_final) the moved images are located in the
// target's tets again. Locating can turn a tet over (an image that left M_j, into a slit of the
// target, is snapped back inside; a sliver with four boundary corners flips on rounding): the
// rows of such tets go back, and only they. docs/methods.md, "Located again, row by row".
#pragma once
#include "shapemap/maps.h"
#include "shapemap/mesh.h"
#include "shapemap/volume/sarap.h"
#include <Eigen/Core>
#include <vector>

namespace shapemap {

// `located` maps the source's vertices (tets and rest shape in `arap`) into M_j's tets; X
// holds its positions. The rows of `candidate` flagged in `moved` replace located's, except
// those of tets that the new positions turn over (det J <= 0 where X's is > 0): these go back
// to located's rows, in rounds (at most `rounds`). Returns the rows put back, and X and
// `located` take the result; or -1 when the rounds did not end with no tet turned over, and
// X and `located` are left as they were.
int take_rows_keeping_positive(const ArapEnergy& arap, const TetMesh& Mj, const BarycentricMap& candidate,
                               std::vector<char> moved, BarycentricMap& located, Eigen::MatrixXd& X,
                               int rounds = 10);

// The last stage's interiors: X's rows `interior` (relaxed images in M_j; the other rows as
// `located` holds them, whose positions are X_before) located in M_j and taken as above.
// X becomes the positions of the result (X_before when it returns -1).
int relocate_interior(const ArapEnergy& arap, const TetMesh& Mj, const std::vector<int>& interior,
                      const Eigen::MatrixXd& X_before, Eigen::MatrixXd& X, BarycentricMap& located, int rounds = 10);

}  // namespace shapemap

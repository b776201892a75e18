// Untangling of a tet map by the regularized energy of Garanzha, Kaporin, Kudryavtseva,
// Protais, Ray, Sokolov 2021 ("Foldover-free maps in 50 lines of code"): a shape term and a
// volume term in which det J is replaced by chi(det J, eps) = (det J + sqrt(eps^2 +
// det J^2)) / 2, positive for every det J, so the energy is finite on inverted tets; eps is
// lowered between minimizations until no tet is inverted. The volume map's last landing
// step (docs/methods.md, "Untangling with the regularized energy").
#pragma once
#include "shapemap/geometry/closest_point.h"
#include "shapemap/mesh.h"
#include "shapemap/volume/sarap.h"
#include <Eigen/Core>
#include <functional>
#include <vector>

namespace shapemap {

// chi(D, eps) = (D + sqrt(eps^2 + D^2)) / 2 and its derivative in D.
double foldover_chi(double D, double eps, double* dchi = nullptr);

// F_eps(J) = (1 - theta) tr(J^T J) / chi^(2/3) + theta (det^2 J + 1) / chi, chi =
// chi(det J, eps): the shape term is 3 and the volume term 2 at a rotation, both grow
// without bound as det J goes to 0+ when eps -> 0. dF (if non-null) receives dF/dJ.
double foldover_free_distortion(const Eigen::Matrix3d& J, double eps, double theta, Eigen::Matrix3d* dF);

struct FoldoverFreeOptions {
  double theta = 0.5;          // weight of the volume term (the paper's lambda: 1/2)
  int max_rounds = 60;         // eps updates
  int lbfgs_iterations = 300;  // per round
  int lbfgs_memory = 10;
  // Stop once every tet has det J above this: a map file stores barycentric coordinates in
  // decimal, so a tet at det J ~ 1e-15 may come back with either sign.
  double min_det = 1e-3;
  // Or once the smallest det J has not risen for this many rounds (a fold that the free
  // vertices cannot undo: eps settles where the rule keeps it, and more rounds only cost).
  int stall_rounds = 5;
};

struct FoldoverFreeResult {
  int rounds = 0;
  double min_det = 0;  // smallest det J over the tets at the end
  double eps = 0;      // the last eps
};

// Extra terms on the positions (e.g. springs that keep images inside the target): returns
// the value and adds the gradient to *grad (n×3, already sized) when non-null.
using RowsTerm = std::function<double(const Eigen::MatrixXd& Y, Eigen::MatrixXd* grad)>;

// Minimizes sum_{k in tets} w_k F_eps(J_k(Y)) + extra(Y) over the rows `free` of Y
// (n×3; the other rows fixed), J_k and w_k from `rest` (the map's source tets and their
// weights v_k / 2c), lowering eps by the rule of Garanzha et al. (Sec. 4 of their paper:
// sigma = max(1 - E_new / E_old, 1/10), mu = (1 - sigma) chi(D-, eps), eps <- 2 sqrt(mu (mu -
// D-)) while the smallest det J, D-, is below mu). Starts at eps = sqrt(1e-12 + 0.04 min(D-,
// 0)^2); stops when D- > opt.min_det, after opt.max_rounds, or on a stall.
FoldoverFreeResult untangle_foldover_free(const ArapEnergy& rest, const std::vector<int>& tets,
                                          const std::vector<int>& free, const RowsTerm& extra,
                                          const FoldoverFreeOptions& opt, Eigen::MatrixXd& Y);

// The volume map's landing (symmetric_map.cpp, its last step): Y holds the images in M_j
// of M_i's vertices (the source tets and weights in `arap`), the rows of M_i's boundary
// vertices (on_bd_i) near dM_j. The tets with det J <= flat_det and `rings` rings of
// vertices around them are untangled by untangle_foldover_free with the other vertices
// held; springs keep the free images in M_j (stiffness 1e6 w/e^2 on the distance to M_j
// outside it, w the mean weight, e the edge of a regular tet of the mean volume) and the
// boundary rows on dM_j (1e4 w/e^2 on the distance to dM_j, either side), so boundary
// images slide along dM_j or go into M_j where a tet needs room.
struct InTarget {
  const TetMesh& Mj;
  const TriMesh& dMj;               // its boundary surface
  const ClosestPoint3& boundary_j;  // over dMj's triangles
  const TetLocator& tets_j;         // M_j's tets
};
FoldoverFreeResult untangle_in_target(const ArapEnergy& arap, const std::vector<std::vector<int>>& vv,
                                      const std::vector<char>& on_bd_i, const InTarget& target, int rings,
                                      double flat_det, const FoldoverFreeOptions& opt, Eigen::MatrixXd& Y);

}  // namespace shapemap

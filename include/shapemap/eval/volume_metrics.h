// Quality metrics of volume maps, symmetric-volume-maps Sec. 6.1 / Table 3, for one
// direction i -> j of a map (source M_i, target M_j, images X_ij of M_i's vertices).
#pragma once
#include "shapemap/maps.h"
#include "shapemap/mesh.h"
#include <limits>

namespace shapemap {

struct VolumeMapMetrics {
  int num_tets = 0;
  int n_inv = 0;              // tets with det J <= 0 (Table 3 n_inv)
  double inverted_fraction = 0;
  double d_max = 0;           // Eq. 27 (vertex-sampled Hausdorff distance between the mapped
                              // boundary X(dM_i) and dM_j) / target bbox diagonal: d^_max
  double d_avg = 0;           // Eq. 28 (mean vertex-to-surface distance both ways) / diagonal
  double det_mean = 0;        // mean |det J^| weighted by source tet volume, J^ = J with
  double det_sd = 0;          // unit columns (Sec. 6.1, "normalized as in Li et al. 2021"); SD
  double E_arap = 0;          // Eq. 20 (this direction: 1/(2c_i) sum v_k f(J_k)), unit volumes
  double E_R = std::numeric_limits<double>::quiet_NaN();  // Eq. 18 term (i,j): needs P_ij and
                              // X_ji; 1/c_i^2 ||P_ij X_ji - V_i||^2_{M_i}, unit volumes
  // Where E_R sits (ours; with E_R): the round trip |P_ij X_ji - V_i| of a vertex (through
  // M_j and back) over the source's bbox diagonal, largest and mean over the vertices, and
  // the share of E_R on the boundary vertices of M_i.
  double round_trip_max = std::numeric_limits<double>::quiet_NaN();
  double round_trip_avg = std::numeric_limits<double>::quiet_NaN();
  double E_R_boundary_share = std::numeric_limits<double>::quiet_NaN();
  bool has_truth = false;     // error against ground-truth images (when given):
  double truth_mean = 0;      // mean |X - X_true| / target bbox diagonal
  double truth_max = 0;       // max  |X - X_true| / target bbox diagonal
};

// Per source vertex v, the round trip |(P_ij X_ji)(v) - V_i(v)| in the source's own
// coordinates: how far v lands from itself through M_j and back (Eq. 18's integrand; the
// `round_trip` field of A_on_B.vtk).
Eigen::VectorXd round_trip_distances(const TetMesh& source, const TetMesh& target, const BarycentricMap& P_ij,
                                     const Eigen::MatrixXd& X_ji);

// source, target: tet meshes in their own coordinates; X: n_i×3 images of the source
// vertices in target coordinates. Optional: P_ij (source vertex -> target tet) with X_ji
// (n_j×3 images of the target vertices in source coordinates) for E_R; truth (n_i×3)
// ground-truth images in target coordinates.
VolumeMapMetrics volume_map_metrics(const TetMesh& source, const TetMesh& target,
                                    const Eigen::MatrixXd& X, const BarycentricMap* P_ij = nullptr,
                                    const Eigen::MatrixXd* X_ji = nullptr,
                                    const Eigen::MatrixXd* truth = nullptr);

}  // namespace shapemap

// Quality metrics of ball-shaped volume-preserving parameterizations
// (isovolumetric-ball-parameterization.txt, Sec. 6: Eq. 45, Eq. 2, Tables 1-2).
#pragma once
#include "shapemap/mesh.h"

namespace shapemap {

struct BallMetrics {
  int num_vertices = 0, num_tets = 0, num_boundary_vertices = 0;
  // D_V(f, tau) (Eq. 45) over all tets: mean, SD, percentiles (Table 1), max.
  double dv_mean = 0, dv_sd = 0, dv_p25 = 0, dv_p50 = 0, dv_p75 = 0, dv_p95 = 0, dv_max = 0;
  double energy = 0;            // E_I(f) (Eq. 2)
  int positive_tets = 0, negative_tets = 0;  // sign of |f(tau)| (zero counts as negative)
  int folded_tets = 0;          // min(positive, negative) (Table 2 "#Foldings")
  // Boundary faces whose image triangle f_i . (f_j x f_k) has the minority sign: the
  // boundary map overlaps itself there even when every tet is positive (a tet squeezed
  // into the cap between the flipped face and the sphere).
  int flipped_boundary_faces = 0;
  // Coverage of the unit ball by the image tets, on a fixed lattice of `coverage_samples`
  // points inside the ball: the share covered by two or more image tets (the map overlaps
  // itself there: not bijective even when folded_tets = 0) and the share covered by none
  // (the gaps between the inscribed polyhedral boundary and the sphere, plus holes).
  double overlap_fraction = 0, uncovered_fraction = 0;
  int coverage_samples = 0;
  double boundary_sphere_error = 0;  // max over boundary vertices of | ||f(v)|| - 1 |
  double max_radius = 0;             // max over all vertices of ||f(v)||
};

// Per-tet local volume distortion D_V(f, tau) (Eq. 45): V n×3 domain, T m×4 positively
// oriented, f n×3 images. Returns m values.
Eigen::VectorXd ball_volume_distortion(const Eigen::MatrixXd& V, const Eigen::MatrixXi& T,
                                       const Eigen::MatrixXd& f);

// Shares of ~`samples` lattice points in the unit ball covered by >= 2 and by 0 image
// tets of f (n×3) over T. Deterministic (fixed lattice with an irrational offset).
void ball_coverage(const Eigen::MatrixXd& f, const Eigen::MatrixXi& T, int samples,
                   double& overlap_fraction, double& uncovered_fraction, int& num_samples);

// All metrics of the ball map f (n×3) of mesh.
BallMetrics ball_metrics(const TetMesh& mesh, const Eigen::MatrixXd& f);

}  // namespace shapemap

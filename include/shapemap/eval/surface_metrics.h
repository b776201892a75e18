// The Blended Intrinsic Maps benchmark protocol (Kim et al. 2011, Sec. 8.2): for every
// ground-truth correspondence p -> f_true(p), the geodesic distance on the target
// d_M2(f(p), f_true(p)) normalized by sqrt(area(M2)); summarized as a cumulative curve
// (fraction of correspondences with error <= D for D = 0, 0.01, ..., 0.25), its mean
// and its maximum.
//
// Geodesics by the heat method on the target from the true image, snapped to the
// nearest vertex of its face (distances are exact at vertices up to the heat method's
// discretization error); the predicted point reads the distance field barycentrically.
#pragma once
#include "shapemap/maps.h"
#include "shapemap/mesh.h"
#include "shapemap/progress.h"
#include <vector>

namespace shapemap {

struct SurfaceErrorCurve {
  std::vector<double> thresholds;  // 0, 0.01, ..., 0.25
  std::vector<double> fraction;    // fraction of correspondences with error <= threshold
  Eigen::VectorXd errors;          // normalized geodesic error per evaluated correspondence
  Eigen::VectorXi evaluated;       // source vertex of each error
  double mean = 0, max = 0;
  double within_0_1 = 0;           // fraction with error <= 0.1 (the headline number)
  int count = 0;
};

struct SurfaceErrorOptions {
  double max_threshold = 0.25;     // Sec. 8.2 plots, x-axis range
  double threshold_step = 0.01;
  int max_points = 0;              // dense truth: evaluate at most this many source vertices
                                   // (evenly strided); 0 = all
  double heat_t_factor = 1.0;
};

// Dense ground truth: map and truth are maps of the source vertices onto target (V,F).
SurfaceErrorCurve surface_map_error(const BarycentricMap& map, const BarycentricMap& truth,
                                    const Eigen::MatrixXd& V_target, const Eigen::MatrixXi& F_target,
                                    const SurfaceErrorOptions& options = {},
                                    const ProgressCallback& progress = {});

// Sparse landmarks: landmarks_source[i] on the source corresponds to vertex
// landmarks_target[i] of the target.
SurfaceErrorCurve surface_landmark_error(const BarycentricMap& map, const std::vector<int>& landmarks_source,
                                         const std::vector<int>& landmarks_target,
                                         const Eigen::MatrixXd& V_target, const Eigen::MatrixXi& F_target,
                                         const SurfaceErrorOptions& options = {});

// Eq. 2 on a dense map: per source vertex confidence 2 / (r + 1/r), r the ratio of
// one-ring areas (mapped / source), both surfaces normalized to unit area; and its
// area-weighted mean (the paper's integrated confidence).
Eigen::VectorXd surface_map_confidence(const Eigen::MatrixXd& V_source, const Eigen::MatrixXi& F_source,
                                       const Eigen::MatrixXd& mapped_positions, double target_area,
                                       double* integrated = nullptr);

}  // namespace shapemap

// Geodesic distances by the heat method (Crane, Weischedel, Wardetzky 2013) with
// prefactored CHOLMOD solvers: build once, query many sources.
#pragma once
#include "shapemap/geometry/sparse_cholesky.h"
#include <Eigen/Core>
#include <Eigen/Sparse>
#include <vector>

namespace shapemap {

class HeatGeodesics {
 public:
  // t = t_factor * h^2 with h the mean edge length (the paper's default t_factor = 1).
  HeatGeodesics(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, double t_factor = 1.0);
  // Distances from one vertex / from a set of vertices (distance to the nearest), n×1,
  // shifted so the minimum over the sources is 0.
  Eigen::VectorXd distance(int source) const;
  Eigen::VectorXd distance(const std::vector<int>& sources) const;
  // Many single-source queries at once, parallel over sources: n × sources.size().
  Eigen::MatrixXd distances(const std::vector<int>& sources) const;
  int num_vertices() const;

 private:
  Eigen::MatrixXd V_;
  Eigen::MatrixXi F_;
  Eigen::VectorXd mass_;
  // Simplicial: distances() solves on both factors from several threads at once, and the
  // supernodal solve calls BLAS, which Debian's serial OpenBLAS does not make thread-safe
  // (measured: 3 of 40 runs of a BIM test with 8 threads gave another map).
  SparseCholesky heat_{SparseCholesky::Method::Simplicial}, poisson_{SparseCholesky::Method::Simplicial};  // (M + tL), L + eps*M
  // per-face gradient operator data
  Eigen::MatrixXd grad_[3];  // m×3: gradient of the hat function of corner j in face f
  Eigen::VectorXd area_;
  Eigen::MatrixXd cot_;      // m×3: cot of the angle at corner j
};

}  // namespace shapemap

// Mass matrices (diagonal, returned as vectors).
#pragma once
#include <Eigen/Core>

namespace shapemap {

// Triangles, barycentric lumping: M_ii = sum of areas of incident faces / 3.
Eigen::VectorXd lumped_mass(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F);
// Triangles, mixed Voronoi areas (Meyer et al. 2003): Voronoi cells for non-obtuse
// triangles, area/2 at the obtuse corner and area/4 at the others otherwise.
Eigen::VectorXd voronoi_mass(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F);
// Tets: M_ii = sum of |volumes| of incident tets / 4.
Eigen::VectorXd tet_lumped_mass(const Eigen::MatrixXd& V, const Eigen::MatrixXi& T);

}  // namespace shapemap

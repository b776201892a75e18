// Lumped and mixed-Voronoi mass matrices (diagonals).
#include "shapemap/geometry/mass.h"
#include "shapemap/geometry/tet_volume.h"
#include "shapemap/error.h"
#include "shapemap/mesh.h"
#include <Eigen/Geometry>
#include <cmath>
#include <string>

namespace shapemap {

namespace {

// Sums per-corner contributions C (m×k) into vertices serially (deterministic).
Eigen::VectorXd scatter(const Eigen::MatrixXi& E, const Eigen::MatrixXd& C, Eigen::Index n) {
  Eigen::VectorXd M = Eigen::VectorXd::Zero(n);
  for (Eigen::Index f = 0; f < E.rows(); ++f)
    for (Eigen::Index c = 0; c < E.cols(); ++c) M(E(f, c)) += C(f, c);
  return M;
}

// A mass diagonal from its corner shares: `corners(e, C)` fills row e of C (m×k) for each
// element in parallel, then scatter() sums the rows into the vertices.
template <class Corners>
Eigen::VectorXd corner_mass(const Eigen::MatrixXd& V, const Eigen::MatrixXi& E, int k, const char* name,
                            Corners corners) {
  require_element_indices(E, V.rows(), k, name);
  const Eigen::Index m = E.rows();
  Eigen::MatrixXd C(m, k);
#pragma omp parallel for schedule(static)
  for (Eigen::Index e = 0; e < m; ++e) corners(e, C);
  return scatter(E, C, V.rows());
}

}  // namespace

Eigen::VectorXd lumped_mass(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) {
  return corner_mass(V, F, 3, "lumped_mass", [&](Eigen::Index f, Eigen::MatrixXd& C) {
    const Eigen::Vector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
    C.row(f).setConstant((b - a).cross(c - a).norm() / 6.0);
  });
}

Eigen::VectorXd voronoi_mass(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) {
  return corner_mass(V, F, 3, "voronoi_mass", [&](Eigen::Index f, Eigen::MatrixXd& C) {
    Eigen::Vector3d p[3];
    for (int c = 0; c < 3; ++c) p[c] = V.row(F(f, c));
    const double two_area = (p[1] - p[0]).cross(p[2] - p[0]).norm();
    const double area = 0.5 * two_area;
    // cot of the angle at each corner and squared length of the opposite edge.
    double cot[3], dot[3], l2[3];
    for (int c = 0; c < 3; ++c) {
      const Eigen::Vector3d u = p[(c + 1) % 3] - p[c], v = p[(c + 2) % 3] - p[c];
      dot[c] = u.dot(v);
      cot[c] = two_area > 0 ? dot[c] / two_area : 0.0;
      l2[c] = (p[(c + 2) % 3] - p[(c + 1) % 3]).squaredNorm();
    }
    int obtuse = -1;
    for (int c = 0; c < 3; ++c)
      if (dot[c] < 0) obtuse = c;
    for (int c = 0; c < 3; ++c) {
      if (obtuse >= 0) {
        C(f, c) = obtuse == c ? area / 2 : area / 4;
      } else {
        // Meyer et al. 2003 Eq. 7: (1/8) sum over the two incident edges of |e|^2 cot(opposite).
        const int j = (c + 1) % 3, k = (c + 2) % 3;
        // Edge c-j is opposite corner k (length l2[k]); edge c-k is opposite corner j.
        C(f, c) = (l2[k] * cot[k] + l2[j] * cot[j]) / 8.0;
      }
    }
  });
}

Eigen::VectorXd tet_lumped_mass(const Eigen::MatrixXd& V, const Eigen::MatrixXi& T) {
  return corner_mass(V, T, 4, "tet_lumped_mass", [&](Eigen::Index t, Eigen::MatrixXd& C) {
    const Eigen::Vector3d a = V.row(T(t, 0)), b = V.row(T(t, 1)), c = V.row(T(t, 2)),
                          d = V.row(T(t, 3));
    C.row(t).setConstant(std::abs(signed_tet_volume6(a, b, c, d)) / 24.0);
  });
}

}  // namespace shapemap

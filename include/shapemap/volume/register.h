// Volume-preserving registration of two tet meshes through their ball parameterizations
// (isovolumetric-ball-parameterization.txt, Sec. 7): f_s : M_s -> B^3 by Algorithm 1,
// rotations g_s by volume-weighted Procrustes, h = g_1^{-1} g_0, and
// phi = f_1^{-1} o h o f_0 by point location in the ball-mapped tet mesh of M_1.
// The same two ball maps also give the reverse map psi = f_0^{-1} o h^{-1} o f_1 (our
// addition: both directions initialize the symmetric volume map, `volume-map --init ball`).
#pragma once
#include "shapemap/maps.h"
#include "shapemap/mesh.h"
#include "shapemap/progress.h"
#include "shapemap/volume/ball_param.h"
#include <string>
#include <vector>

namespace shapemap {

// vol(v) = 1/4 sum over tets containing v of |tau| (Sec. 7). V n×3, T m×4 -> n.
Eigen::VectorXd vertex_volumes(const Eigen::MatrixXd& V, const Eigen::MatrixXi& T);

// g = argmin_{g in SO(3)} sum_v ||g f(v) - v||^2 w(v) (Sec. 7), f, V n×3, w n.
// V is used as given (register_through_ball centres it first, see below).
Eigen::Matrix3d ball_procrustes_rotation(const Eigen::MatrixXd& f, const Eigen::MatrixXd& V,
                                         const Eigen::VectorXd& w);

// Frame k of the linear homotopy H(v, t) = (1 - t) v + t phi(v) (Eq. 46), t = k/(K-1),
// 0 <= k < K, K >= 2. V, phi n×3. One frame at a time: K frames of a large mesh need not
// fit in memory together (the CLI writes each as it is made).
Eigen::MatrixXd linear_homotopy_frame(const Eigen::MatrixXd& V, const Eigen::MatrixXd& phi, int k,
                                      int K);

struct RegisterOptions {
  BallParamOptions ball;    // Algorithm 1 for both meshes
  bool center = true;       // Procrustes against volume-centred vertices (the ball is centred
                            // at the origin; off: the raw coordinates v of Sec. 7)
};

// How the points h f_0(v) were found in the target's ball mesh. Boundary vertices lie on the
// unit sphere, outside the inscribed polyhedral ball, and are always snapped to its surface;
// an interior vertex outside fell into a gap of the target's ball map.
struct BallLocation {
  int outside = 0;                // points outside the polyhedral ball (snapped to the closest tet)
  int outside_interior = 0;       // of them, images of interior vertices of the source
  double max_snap = 0;            // largest snap distance (ball units) over all points
  double max_snap_interior = 0;   // ... over the interior vertices of the source
};

struct RegisterResult {
  BallParamResult ball_A, ball_B;      // f_0, f_1
  Eigen::Matrix3d g_A = Eigen::Matrix3d::Identity(), g_B = Eigen::Matrix3d::Identity();  // g_0, g_1
  Eigen::Matrix3d h = Eigen::Matrix3d::Identity();  // g_1^{-1} g_0
  BarycentricMap map_AB;               // vertex of A -> tet of B + barycentric coordinates
  Eigen::MatrixXd A_on_B;              // phi(v), n_A×3, in B's coordinates
  BarycentricMap map_BA;               // psi: vertex of B -> tet of A (h^{-1} f_1 located in f_0)
  Eigen::MatrixXd B_on_A;              // psi(v), n_B×3, in A's coordinates
  double d_phi = 0;                    // d(phi) = sum ||v - phi(v)|| vol(v) / |M_0| (Sec. 7)
  double d_phi_relative = 0;           // d(phi) / bounding-box diagonal of A
  BallLocation located_AB;             // h f_0(v) in B's ball mesh
  BallLocation located_BA;             // h^{-1} f_1(v) in A's ball mesh
  double seconds_locate = 0, seconds_total = 0;
};

// A, B: tet meshes of topological balls. Throws InputError ("<nameA>: ..." or
// "<nameB>: ...") if either is not a ball.
RegisterResult register_through_ball(const TetMesh& A, const TetMesh& B,
                                     const RegisterOptions& opt = {},
                                     const ProgressCallback& progress = {},
                                     const std::string& nameA = "A",
                                     const std::string& nameB = "B");

}  // namespace shapemap

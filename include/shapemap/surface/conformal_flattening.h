// Conformal flattening of a closed genus-0 surface to the extended complex plane
// (Blended Intrinsic Maps, Sec. 4), lifted to the Riemann sphere.
//
// Method: the cotangent "dipole" map of the punctured sphere (Angenent, Haker,
// Tannenbaum, Kikinis 1999; Haker et al. 2000). One face ABC (the pole) is punctured;
// the conformal map z: M \ {p} -> C solves Δz = (∂/∂u − i ∂/∂v) δ_p, discretized as
// L z = b with L the cotangent Laplacian and b supported on A, B, C:
//   Re b: A -1/|AB|, B +1/|AB|;  Im b: A (1−θ)/|CE|, B θ/|CE|, C −1/|CE|,
// where E = A + θ (B − A) is the foot of C on AB. The point p goes to ∞; the face ABC
// covers the outside of the image. The plane is then identified with the unit sphere
// by inverse stereographic projection and Möbius-centered (area centroid at the
// origin), so that the removed pole and ∞ are ordinary points for point location.
// (docs/methods.md explains why this instead of mid-edge uniformization.)
#pragma once
#include <Eigen/Core>
#include <Eigen/Geometry>

namespace shapemap {

struct ConformalFlatteningOptions {
  int pole_face = -1;          // face punctured to ∞ (Sec. 4); -1 = face 0 (callers choose)
  bool center = true;          // Möbius-center the area distribution on the sphere
  int centering_iterations = 100;
  double centering_tolerance = 1e-6;  // stop when |area centroid| is below
};

struct ConformalFlattening {
  Eigen::MatrixXd plane;        // n×2 dipole map (before the sphere lift), for diagnostics
  Eigen::MatrixXd sphere;       // n×3 unit vectors, faces CCW seen from outside
  Eigen::VectorXd area_factor;  // n: (spherical area of the one-ring)/(surface area of the one-ring)
  int pole_face = -1;
  double centroid_norm = 0;     // |area centroid| on the sphere after centering
  int flipped_faces = 0;        // faces with negative orientation on the sphere
  // The dipole map folded with the cotangent weights (non-Delaunay meshes with thin parts,
  // e.g. the camel poses' legs) and was recomputed without the negative weights, which
  // folded less (docs/methods.md, "Non-Delaunay meshes"); cotan_flipped_faces: the folds of
  // the first try.
  bool dropped_negative_weights = false;
  int cotan_flipped_faces = 0;
};

// V: n×3, F: m×3 closed, connected, genus 0, consistently oriented. The dipole map with the
// cotangent Laplacian; if it has flipped faces on the sphere, again with the negative
// weights dropped (drop_negative_weights), and the one with fewer flipped faces is kept.
// Throws shapemap::Error if the linear solve fails.
ConformalFlattening conformal_flattening(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F,
                                         const ConformalFlatteningOptions& options = {});

// The planar dipole map alone (n×2), pole face pole_face; drop_negative: with the cotangent
// Laplacian's negative weights dropped.
Eigen::MatrixXd dipole_flattening(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, int pole_face,
                                  bool drop_negative = false);

// Angle distortion of a map of the mesh (V,F) to X (n×2 or n×3, same faces): per face,
// the mean over its three corners of |angle in X − angle in V| (radians). Faces listed
// in `skip` (e.g. the pole face) get 0.
Eigen::VectorXd angle_distortion(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F,
                                 const Eigen::MatrixXd& X, int skip = -1);

// Area of the spherical triangle with unit-vector corners a, b, c (Van Oosterom–Strackee).
double spherical_triangle_area(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                               const Eigen::Vector3d& c);

}  // namespace shapemap

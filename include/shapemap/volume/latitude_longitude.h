// Latitude-longitude map of a closed genus-0 surface onto the unit sphere (Brechbuehler,
// Gerig, Kuebler 1995, "Parametrization of closed surfaces for 3-D shape description", the
// SPHARM initialization): a start for the spherical area-preserving map (sphere_param.h)
// that does not shrink elongated parts exponentially, as conformal starts do (a tube of
// length L and width w gets a conformal factor ~exp(-pi L / w)).
//  - poles a, b: farthest-point double sweeps of Euclidean distances and of edge-path
//    lengths (two candidates; the map with fewer folded sphere faces is kept);
//  - latitude u: harmonic, u(a) = 0, u(b) = 1, with the cotangent weights clamped to at
//    least 1% of their median, so the discrete maximum principle holds: no interior extrema,
//    hence (on a sphere) no saddles, every level set one circle; u grows about linearly
//    along a tube;
//  - longitude phi: harmonic with a jump of 2 pi across the date line (the steepest ascent
//    path of u from a to b): the minimizer of sum_e w_e (phi_i - phi_j - 2 pi (l_i(e) -
//    l_j(e)))^2, l_p(e) = 1 for an edge leaving path vertex p on the left of the path
//    (east of a walk from a, where phi grows); poles left out, one vertex pinned;
//  - polar angle theta by area: 1 - cos(theta_i) = 2 * (target share of the vertices with
//    smaller u, plus half of vertex i's own), monotone in u.
// The continuous analogue ((u, conjugate harmonic) on an annulus) is an embedding; the
// discrete (u, phi) chart can have a few inverted faces, and on the sphere faces thin in
// theta and long in phi can fold as flat chord triangles (docs/methods.md).
#pragma once
#include "shapemap/mesh.h"
#include <Eigen/Sparse>
#include <vector>

namespace shapemap {

struct LatitudeLongitudeMap {
  Eigen::MatrixXd S;            // n×3 unit vectors, outward by majority; empty on failure
  int pole_a = -1, pole_b = -1; // S(a) = (0, 0, 1), S(b) = (0, 0, -1)
  Eigen::VectorXd latitude;     // u in [0, 1]
  Eigen::VectorXd longitude;    // phi in radians, not wrapped (S uses cos, sin of it)
  std::vector<int> date_line;   // vertices from a to b
};

// surface: closed genus-0 triangle mesh, outward oriented. laplacian: its cotangent
// Laplacian in the PSD convention of geometry/laplacian.h (computed when empty).
// face_shares: target area per face (default: the triangle areas). Returns an empty S when
// the construction fails (e.g. a steepest ascent path that does not reach b).
LatitudeLongitudeMap latitude_longitude_map(const TriMesh& surface,
                                           const Eigen::SparseMatrix<double>& laplacian = {},
                                           const Eigen::VectorXd& face_shares = {});

}  // namespace shapemap

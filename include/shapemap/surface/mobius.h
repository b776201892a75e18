// Möbius transformations of the extended complex plane C ∪ {∞} and the stereographic
// identification of C ∪ {∞} with the unit sphere (Blended Intrinsic Maps, Sec. 4;
// Lipman & Funkhouser 2009). Points are kept in homogeneous coordinates [u : v]
// (z = u / v, ∞ = [1 : 0]) so that no formula divides by zero.
#pragma once
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <complex>

namespace shapemap {

using Complex = std::complex<double>;

// A point of the extended complex plane, z = u / v.
struct Homogeneous {
  Complex u{0.0}, v{1.0};
  Complex value() const { return u / v; }  // may be inf when v == 0
};

// Inverse stereographic projection from the north pole: [u : v] -> unit vector
// (2 Re(u v̄), 2 Im(u v̄), |u|² - |v|²) / (|u|² + |v|²);  0 -> south pole, ∞ -> north pole.
Eigen::Vector3d sphere_from_plane(const Homogeneous& z);
// Stereographic projection, the inverse of the above (x must be a unit vector). Uses the
// better conditioned of the two equivalent homogeneous forms.
Homogeneous plane_from_sphere(const Eigen::Vector3d& x);

// m(z) = (a z + b) / (c z + d), normalized to a d - b c = 1.
struct Mobius {
  Complex a{1.0}, b{0.0}, c{0.0}, d{1.0};

  // The unique Möbius map with m(z[k]) = w[k], k = 0, 1, 2 (distinct points): the map
  // a triplet of feature correspondences generates (Sec. 4). Throws shapemap::Error if
  // points coincide.
  static Mobius from_three_points(const Homogeneous z[3], const Homogeneous w[3]);
  static Mobius from_three_points(const Complex z[3], const Complex w[3]);

  Mobius inverse() const;                     // m^{-1}
  Mobius operator*(const Mobius& o) const;    // composition (this ∘ o)
  Homogeneous operator()(const Homogeneous& z) const;
  Complex operator()(const Complex& z) const;
  // The action on the unit sphere (through stereographic projection).
  Eigen::Vector3d apply_sphere(const Eigen::Vector3d& x) const;
  // Ratio of spherical area elements at m(z) and z, |m'|²_sphere =
  // ((|u|²+|v|²) / (|a u + b v|² + |c u + d v|²))²  (needs ad - bc = 1).
  double sphere_area_factor(const Homogeneous& z) const;
};

}  // namespace shapemap

// Möbius transformations and stereographic projection.
#include "shapemap/surface/mobius.h"
#include "shapemap/error.h"
#include <cmath>

namespace shapemap {

Eigen::Vector3d sphere_from_plane(const Homogeneous& z) {
  const double nu = std::norm(z.u), nv = std::norm(z.v);
  const Complex uv = z.u * std::conj(z.v);
  const double s = nu + nv;
  if (!(s > 0)) return Eigen::Vector3d(0, 0, -1);
  return Eigen::Vector3d(2 * uv.real() / s, 2 * uv.imag() / s, (nu - nv) / s);
}

Homogeneous plane_from_sphere(const Eigen::Vector3d& x) {
  // z = (x + i y) / (1 - z) = (1 + z) / (x - i y).
  Homogeneous h;
  if (x.z() <= 0) {
    h.u = Complex(x.x(), x.y());
    h.v = Complex(1 - x.z(), 0);
  } else {
    h.u = Complex(1 + x.z(), 0);
    h.v = Complex(x.x(), -x.y());
  }
  return h;
}

namespace {
Mobius normalized(Complex a, Complex b, Complex c, Complex d) {
  Complex det = a * d - b * c;
  if (!(std::abs(det) > 0) || !std::isfinite(std::abs(det)))
    throw Error("Möbius transformation: degenerate (coincident points)");
  Complex s = std::sqrt(det);
  return Mobius{a / s, b / s, c / s, d / s};
}
// det[p, q] = p.u q.v - p.v q.u (zero iff p and q are the same point).
Complex hdet(const Homogeneous& p, const Homogeneous& q) { return p.u * q.v - p.v * q.u; }
// The map sending z0 -> 0, z1 -> 1, z2 -> ∞ (cross ratio), as an unnormalized matrix.
void cross_ratio_matrix(const Homogeneous z[3], Complex& a, Complex& b, Complex& c, Complex& d) {
  Complex d12 = hdet(z[1], z[2]), d10 = hdet(z[1], z[0]);
  // T(p) = det(p, z0) det(z1, z2) / (det(p, z2) det(z1, z0)); det(p, q) = u q.v - v q.u.
  a = z[0].v * d12;
  b = -z[0].u * d12;
  c = z[2].v * d10;
  d = -z[2].u * d10;
}
}  // namespace

Mobius Mobius::from_three_points(const Homogeneous z[3], const Homogeneous w[3]) {
  Complex a1, b1, c1, d1, a2, b2, c2, d2;
  cross_ratio_matrix(z, a1, b1, c1, d1);
  cross_ratio_matrix(w, a2, b2, c2, d2);
  // Scale each to unit determinant before composing (conditioning).
  Mobius T1 = normalized(a1, b1, c1, d1), T2 = normalized(a2, b2, c2, d2);
  Mobius m = T2.inverse() * T1;
  return normalized(m.a, m.b, m.c, m.d);
}

Mobius Mobius::from_three_points(const Complex z[3], const Complex w[3]) {
  Homogeneous hz[3], hw[3];
  for (int k = 0; k < 3; ++k) {
    hz[k].u = z[k];
    hw[k].u = w[k];
  }
  return from_three_points(hz, hw);
}

Mobius Mobius::inverse() const { return Mobius{d, -b, -c, a}; }

Mobius Mobius::operator*(const Mobius& o) const {
  return Mobius{a * o.a + b * o.c, a * o.b + b * o.d, c * o.a + d * o.c, c * o.b + d * o.d};
}

Homogeneous Mobius::operator()(const Homogeneous& z) const {
  Homogeneous r;
  r.u = a * z.u + b * z.v;
  r.v = c * z.u + d * z.v;
  return r;
}

Complex Mobius::operator()(const Complex& z) const { return (a * z + b) / (c * z + d); }

Eigen::Vector3d Mobius::apply_sphere(const Eigen::Vector3d& x) const {
  return sphere_from_plane((*this)(plane_from_sphere(x)));
}

double Mobius::sphere_area_factor(const Homogeneous& z) const {
  Homogeneous w = (*this)(z);
  double num = std::norm(z.u) + std::norm(z.v);
  double den = std::norm(w.u) + std::norm(w.v);
  double s = num / den;
  return s * s;
}

}  // namespace shapemap

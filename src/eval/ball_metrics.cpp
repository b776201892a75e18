// Metrics of ball maps: D_V (Eq. 45), E_I (Eq. 2), foldings, boundary-on-sphere error.
#include "shapemap/eval/ball_metrics.h"
#include "shapemap/geometry/tet_volume.h"
#include "shapemap/error.h"
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <vector>

namespace shapemap {

namespace {

// Linear-interpolated percentile q in [0,1] of sorted values.
double percentile(const std::vector<double>& s, double q) {
  if (s.empty()) return 0;
  const double pos = q * double(s.size() - 1);
  const size_t i = size_t(std::floor(pos));
  const size_t j = std::min(s.size() - 1, i + 1);
  const double t = pos - double(i);
  return (1 - t) * s[i] + t * s[j];
}

}  // namespace

void ball_coverage(const Eigen::MatrixXd& f, const Eigen::MatrixXi& T, int samples,
                   double& overlap_fraction, double& uncovered_fraction, int& num_samples) {
  // Lattice spacing for ~samples points in the ball; an irrational offset keeps points off
  // shared faces of a regular input.
  const double h = std::cbrt(4.0 * M_PI / 3.0 / std::max(1, samples));
  const double off[3] = {0.5 * h * (std::sqrt(2.0) - 1), 0.5 * h * (std::sqrt(3.0) - 1), 0.5 * h * (std::sqrt(5.0) - 2)};
  std::vector<Eigen::Vector3d> pts;
  const int K = int(std::ceil(1.0 / h)) + 1;
  for (int i = -K; i <= K; ++i)
    for (int j = -K; j <= K; ++j)
      for (int k = -K; k <= K; ++k) {
        const Eigen::Vector3d p(i * h + off[0], j * h + off[1], k * h + off[2]);
        if (p.norm() < 1.0) pts.push_back(p);
      }
  // Uniform grid of image-tet bounding boxes over [-1, 1]^3 (tets outside are clipped).
  const int G = std::max(4, int(std::cbrt(double(T.rows()) / 2.0)));
  auto cell = [&](double x) { return std::clamp(int((x + 1.0) * 0.5 * G), 0, G - 1); };
  std::vector<std::vector<int>> bins(size_t(G) * G * G);
  for (Eigen::Index t = 0; t < T.rows(); ++t) {
    Eigen::Vector3d lo = f.row(T(t, 0)).transpose(), hi = lo;
    for (int c = 1; c < 4; ++c) {
      lo = lo.cwiseMin(f.row(T(t, c)).transpose());
      hi = hi.cwiseMax(f.row(T(t, c)).transpose());
    }
    for (int a = cell(lo.x()); a <= cell(hi.x()); ++a)
      for (int b = cell(lo.y()); b <= cell(hi.y()); ++b)
        for (int c = cell(lo.z()); c <= cell(hi.z()); ++c) bins[(size_t(a) * G + b) * G + c].push_back(int(t));
  }
  long over = 0, none = 0;
#pragma omp parallel for schedule(static) reduction(+ : over, none)
  for (long s = 0; s < long(pts.size()); ++s) {
    const Eigen::Vector3d& p = pts[size_t(s)];
    int cnt = 0;
    for (int t : bins[(size_t(cell(p.x())) * G + cell(p.y())) * G + cell(p.z())]) {
      const Eigen::Vector3d a = f.row(T(t, 0)), b = f.row(T(t, 1)), c = f.row(T(t, 2)), d = f.row(T(t, 3));
      const double v = signed_tet_volume6(a, b, c, d);
      if (v == 0) continue;
      // Barycentric coordinates as signed sub-volumes over the tet volume (any orientation).
      const double l0 = (b - p).dot((c - p).cross(d - p)) / v;
      const double l1 = (a - p).dot((d - p).cross(c - p)) / v;
      const double l2 = (a - p).dot((b - p).cross(d - p)) / v;
      const double l3 = (a - p).dot((c - p).cross(b - p)) / v;
      if (l0 >= 0 && l1 >= 0 && l2 >= 0 && l3 >= 0 && ++cnt >= 2) break;
    }
    over += cnt >= 2;
    none += cnt == 0;
  }
  num_samples = int(pts.size());
  overlap_fraction = pts.empty() ? 0 : double(over) / double(pts.size());
  uncovered_fraction = pts.empty() ? 0 : double(none) / double(pts.size());
}

Eigen::VectorXd ball_volume_distortion(const Eigen::MatrixXd& V, const Eigen::MatrixXi& T,
                                       const Eigen::MatrixXd& f) {
  if (f.rows() != V.rows() || f.cols() != 3)
    throw InputError("ball map: expected " + std::to_string(V.rows()) + "×3 coordinates, got " +
                     std::to_string(f.rows()) + "×" + std::to_string(f.cols()));
  const Eigen::VectorXd ve = tet_volumes(V, T), vf = tet_volumes(f, T);
  double Se = 0, Sf = 0;
  for (Eigen::Index t = 0; t < ve.size(); ++t) {
    Se += ve(t);
    Sf += vf(t);
  }
  Eigen::VectorXd D(ve.size());
  for (Eigen::Index t = 0; t < ve.size(); ++t) {
    const double a = ve(t) / Se;
    D(t) = std::abs((vf(t) / Sf - a) / a);  // Eq. 45
  }
  return D;
}

BallMetrics ball_metrics(const TetMesh& mesh, const Eigen::MatrixXd& f) {
  BallMetrics m;
  m.num_vertices = mesh.num_vertices();
  m.num_tets = mesh.num_tets();
  const Eigen::VectorXd D = ball_volume_distortion(mesh.V, mesh.T, f);
  std::vector<double> s(D.data(), D.data() + D.size());
  std::sort(s.begin(), s.end());
  double sum = 0;
  for (double d : s) sum += d;
  m.dv_mean = s.empty() ? 0 : sum / double(s.size());
  double var = 0;
  for (double d : s) var += (d - m.dv_mean) * (d - m.dv_mean);
  m.dv_sd = s.empty() ? 0 : std::sqrt(var / double(s.size()));
  m.dv_p25 = percentile(s, 0.25);
  m.dv_p50 = percentile(s, 0.50);
  m.dv_p75 = percentile(s, 0.75);
  m.dv_p95 = percentile(s, 0.95);
  m.dv_max = s.empty() ? 0 : s.back();
  // E_I (Eq. 2) and foldings.
  const Eigen::VectorXd ve = tet_volumes(mesh.V, mesh.T), vf = tet_volumes(f, mesh.T);
  double Ve = 0, Vf = 0, EV = 0;
  for (Eigen::Index t = 0; t < ve.size(); ++t) {
    Ve += ve(t);
    Vf += vf(t);
    EV += vf(t) * vf(t) / ve(t);
    if (vf(t) > 0)
      ++m.positive_tets;
    else
      ++m.negative_tets;
  }
  m.energy = Vf > 0 ? Ve / Vf * EV - Vf : std::numeric_limits<double>::infinity();
  m.folded_tets = std::min(m.positive_tets, m.negative_tets);
  const TetBoundary b = boundary_surface(mesh);
  m.num_boundary_vertices = int(b.to_volume.size());
  Eigen::MatrixXi Fv(b.surface.F.rows(), 3);  // boundary faces in volume vertex numbers
  for (Eigen::Index q = 0; q < Fv.rows(); ++q)
    for (int c = 0; c < 3; ++c) Fv(q, c) = b.to_volume(b.surface.F(q, c));
  const int pos = positive_origin_cones(f, Fv);
  m.flipped_boundary_faces = std::min(pos, int(Fv.rows()) - pos);
  ball_coverage(f, mesh.T, 100000, m.overlap_fraction, m.uncovered_fraction, m.coverage_samples);
  for (Eigen::Index k = 0; k < b.to_volume.size(); ++k)
    m.boundary_sphere_error =
        std::max(m.boundary_sphere_error, std::abs(f.row(b.to_volume(k)).norm() - 1.0));
  for (Eigen::Index i = 0; i < f.rows(); ++i) m.max_radius = std::max(m.max_radius, f.row(i).norm());
  return m;
}

}  // namespace shapemap

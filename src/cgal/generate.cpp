// Generated creatures and pairs with ground truth (no CGAL here: the meshers are in
// implicit_mesher.cpp and tetrahedralize.cpp, behind src/cgal/internal.h).
//
// Creature: a smooth union (polynomial smooth-min) of an ellipsoid body, a capsule neck
// with an ellipsoid head, a capsule tail and four two-segment legs (thigh and shin
// capsules). The primitives form a tree (each part overlaps only its parent), and
// parts that are not parent and child stay farther apart than the blending width
// (smooth-min with width k adds at most k/4 between two parts, so a gap > k/2 never
// bridges): the surface is connected and genus 0 for every seed. Coordinates: x
// forward (head at +x), y lateral, z up; body length about 2.
//
// Deformation: linear blend skinning on the same skeleton. Each part i has an affine
// map A_i(x) = A_parent(j_i) + R_i D_i (x - j_i) about its joint j_i (R_i: the product
// of the local rotations along the chain, D_i: the part's own scaling); the body map
// is the identity (NearIsometric) or an anisotropic stretch (NonIsometric). Weights:
// softmax of -d_i(x)/tau over the parts' signed distances, so the field is smooth,
// the identity on no part but rigid deep inside each part.
#include "internal.h"
#include "shapemap/error.h"
#include "shapemap/splitmix.h"
#include "shapemap/generate.h"
#include "shapemap/geometry/closest_point.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <memory>
#include <random>

namespace shapemap {
namespace {

// Uniform doubles from a 64-bit Mersenne twister, reproducible across standard
// libraries (std::uniform_real_distribution is not).
class Rng {
 public:
  explicit Rng(std::uint64_t seed) : g_(seed) {}
  double uniform() { return double(g_() >> 11) * (1.0 / 9007199254740992.0); }
  double uniform(double a, double b) { return a + (b - a) * uniform(); }
  double sign() { return uniform() < 0.5 ? -1.0 : 1.0; }

 private:
  std::mt19937_64 g_;
};

std::uint64_t mix(std::uint64_t x) { return splitmix64_hash(x); }

enum PartId { Body = 0, Neck, Head, Tail, Thigh0, Shin0 = Thigh0 + 4, NumParts = Shin0 + 4 };

struct Part {
  bool ellipsoid = false;
  // Capsule: segment a-b, radius r. Ellipsoid: center c, axes R (columns), radii e.
  Eigen::Vector3d a, b;
  double r = 0;
  Eigen::Vector3d c;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d e;
  int parent = -1;
  Eigen::Vector3d joint = Eigen::Vector3d::Zero();  // rotation center relative to the parent
  double blend = 0.1;                                // smooth-min width with the parts before it

  double distance(const Eigen::Vector3d& p) const {
    if (!ellipsoid) {
      Eigen::Vector3d ab = b - a;
      double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
      return (p - a - t * ab).norm() - r;
    }
    // Ellipsoid distance bound (k0 (k0 - 1) / k1, exact on the surface's normal lines
    // near the surface, smooth, negative inside).
    Eigen::Vector3d q = R.transpose() * (p - c);
    double k0 = q.cwiseQuotient(e).norm();
    double k1 = q.cwiseQuotient(e.cwiseProduct(e)).norm();
    if (k1 < 1e-12) return -e.minCoeff();
    return k0 * (k0 - 1) / k1;
  }
};

double smooth_min(double a, double b, double k) {
  double h = std::max(k - std::abs(a - b), 0.0) / k;
  return std::min(a, b) - h * h * k * 0.25;
}

struct Creature {
  std::vector<Part> parts;
  double f(const Eigen::Vector3d& p) const {
    double v = parts[0].distance(p);
    for (size_t i = 1; i < parts.size(); ++i) v = smooth_min(v, parts[i].distance(p), parts[i].blend);
    return v;
  }
};

Eigen::Matrix3d rot(const Eigen::Vector3d& axis, double deg) {
  return Eigen::AngleAxisd(deg * M_PI / 180, axis.normalized()).toRotationMatrix();
}

Creature make_creature_skeleton(std::uint64_t seed) {
  Rng rng(mix(seed * 2 + 1));
  Creature cr;
  cr.parts.resize(NumParts);
  // Body: ellipsoid at the origin, semi-axes (a, b, c).
  const double a = rng.uniform(1.0, 1.25), b = rng.uniform(0.40, 0.50), c = rng.uniform(0.36, 0.46);
  Part& body = cr.parts[Body];
  body.ellipsoid = true;
  body.c = Eigen::Vector3d::Zero();
  body.e = Eigen::Vector3d(a, b, c);

  // Neck: from inside the front of the body, up and forward.
  Part& neck = cr.parts[Neck];
  double neck_up = rng.uniform(40, 60) * M_PI / 180, neck_len = rng.uniform(0.5, 0.65);
  neck.a = Eigen::Vector3d(0.7 * a, 0, 0.25 * c);
  neck.b = neck.a + neck_len * Eigen::Vector3d(std::cos(neck_up), 0, std::sin(neck_up));
  neck.r = rng.uniform(0.13, 0.17);
  neck.parent = Body;
  neck.joint = Eigen::Vector3d(0.85 * a, 0, 0.35 * c);
  neck.blend = 0.12;

  // Head: ellipsoid around the end of the neck, elongated forward and a bit down.
  Part& head = cr.parts[Head];
  head.ellipsoid = true;
  double head_pitch = rng.uniform(-30, -10);
  head.R = rot(Eigen::Vector3d::UnitY(), -head_pitch);  // x axis tilted down
  head.e = Eigen::Vector3d(rng.uniform(0.30, 0.38), rng.uniform(0.19, 0.23), rng.uniform(0.19, 0.23));
  head.c = neck.b + head.R.col(0) * 0.45 * head.e.x();
  head.parent = Neck;
  head.joint = neck.b;
  head.blend = 0.08;

  // Tail: from inside the back of the body, backwards and up or down.
  Part& tail = cr.parts[Tail];
  double tail_pitch = rng.uniform(0, 35) * M_PI / 180, tail_len = rng.uniform(0.5, 0.75);
  tail.a = Eigen::Vector3d(-0.8 * a, 0, 0.15 * c);
  tail.b = tail.a + tail_len * Eigen::Vector3d(-std::cos(tail_pitch), 0, std::sin(tail_pitch));
  tail.r = rng.uniform(0.08, 0.1);
  tail.parent = Body;
  tail.joint = Eigen::Vector3d(-0.92 * a, 0, 0.15 * c);
  tail.blend = 0.1;

  // Legs: hips under the body at x = +-0.7 a, y = +-0.62 b; thigh down (splayed outward a
  // little), knee, shin down to the foot.
  const double thigh_len = rng.uniform(0.40, 0.50), shin_len = rng.uniform(0.40, 0.50);
  const double leg_r = rng.uniform(0.10, 0.125);
  for (int k = 0; k < 4; ++k) {
    const double sx = k < 2 ? 1 : -1, sy = k % 2 == 0 ? 1 : -1;
    Part& thigh = cr.parts[Thigh0 + k];
    Part& shin = cr.parts[Shin0 + k];
    thigh.a = Eigen::Vector3d(sx * 0.7 * a, sy * 0.5 * b, 0);  // inside the body
    Eigen::Vector3d hip_on_surface(sx * 0.7 * a, sy * 0.62 * b, -c * std::sqrt(std::max(0.05, 1 - 0.49 - 0.3844)));
    Eigen::Vector3d dir(sx * rng.uniform(-0.1, 0.15), sy * rng.uniform(0.08, 0.18), -1);
    thigh.b = hip_on_surface + thigh_len * dir.normalized();
    thigh.r = leg_r;
    thigh.parent = Body;
    thigh.joint = hip_on_surface;
    thigh.blend = 0.1;
    Eigen::Vector3d dir2(sx * rng.uniform(-0.15, 0.1), sy * 0.05, -1);
    shin.a = thigh.b;
    shin.b = thigh.b + shin_len * dir2.normalized();
    shin.r = 0.85 * leg_r;
    shin.parent = Thigh0 + k;
    shin.joint = thigh.b;
    shin.blend = 0.05;
  }
  return cr;
}

// Bounding sphere of the parts.
cgal_internal::ImplicitSurface implicit_of(const Creature& cr) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e9), hi = -lo;
  for (const Part& p : cr.parts) {
    if (p.ellipsoid) {
      double rmax = p.e.maxCoeff();
      lo = lo.cwiseMin(p.c - Eigen::Vector3d::Constant(rmax));
      hi = hi.cwiseMax(p.c + Eigen::Vector3d::Constant(rmax));
    } else {
      lo = lo.cwiseMin(p.a.cwiseMin(p.b) - Eigen::Vector3d::Constant(p.r));
      hi = hi.cwiseMax(p.a.cwiseMax(p.b) + Eigen::Vector3d::Constant(p.r));
    }
  }
  cgal_internal::ImplicitSurface s;
  auto shared = std::make_shared<Creature>(cr);
  s.f = [shared](const Eigen::Vector3d& p) { return shared->f(p); };
  s.center = 0.5 * (lo + hi);
  s.radius = 0.5 * (hi - lo).norm() + 0.3;
  return s;
}

// Initial surface crossings on every part: from points inside each part (ellipsoid
// centers; capsule ends and middles), march along 14 directions to the first outside
// sample; the bracketing segment is bisected down to a short one. Crossings closer than
// min_separation to an accepted one are dropped.
std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> initial_segments(
    const Creature& cr, const cgal_internal::ImplicitSurface& s, double min_separation) {
  std::vector<Eigen::Vector3d> seeds;
  for (const Part& p : cr.parts) {
    if (p.ellipsoid) seeds.push_back(p.c);
    else seeds.push_back(p.a), seeds.push_back(0.5 * (p.a + p.b)), seeds.push_back(p.b);
  }
  std::vector<Eigen::Vector3d> dirs;
  for (int a = -1; a <= 1; ++a)
    for (int b = -1; b <= 1; ++b)
      for (int c = -1; c <= 1; ++c)
        if ((a != 0) + (b != 0) + (c != 0) == 1 || (a != 0 && b != 0 && c != 0))
          dirs.push_back(Eigen::Vector3d(a, b, c).normalized());
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> segs;
  std::vector<Eigen::Vector3d> points;
  const double step = 0.02;
  for (const Eigen::Vector3d& p : seeds) {
    if (!(s.f(p) < 0)) continue;
    for (const Eigen::Vector3d& d : dirs) {
      double t = step;
      while (s.f(p + t * d) < 0 && t < 2 * s.radius) t += step;
      Eigen::Vector3d in = p + (t - step) * d, out = p + t * d;
      if (!(s.f(out) > 0)) continue;
      for (int it = 0; it < 12; ++it) {
        Eigen::Vector3d mid = 0.5 * (in + out);
        (s.f(mid) < 0 ? in : out) = mid;
      }
      Eigen::Vector3d x = 0.5 * (in + out);
      bool close = false;
      for (const Eigen::Vector3d& q : points) close |= (q - x).norm() < min_separation;
      if (close) continue;
      points.push_back(x);
      segs.push_back({in, out});
    }
  }
  return segs;
}

// Mesh_3 with facet_size s on these creatures gives about kDensity * area / s^2
// vertices (calibrated on seeds 1..8 at 2k..20k vertices).
constexpr double kDensity = 1.15;
constexpr double kDistanceRatio = 0.06;  // facet_distance / facet_size

TriMesh mesh_with_retries(const Creature& cr, double area_estimate, int target_vertices,
                          std::uint64_t seed, const std::string& what) {
  cgal_internal::ImplicitSurface s = implicit_of(cr);
  double fs = std::sqrt(kDensity * area_estimate / target_vertices);
  for (int attempt = 0; attempt < 6; ++attempt) {
    s.initial_segments = initial_segments(cr, s, 1.5 * fs);
    TriMesh m = cgal_internal::mesh_implicit_surface(s, fs, kDistanceRatio * fs,
                                                     unsigned(mix(seed + attempt) & 0x7fffffff));
    if (cgal_internal::surface_topology(m).genus0()) {
      if (enclosed_volume(m.V, m.F) < 0) m.F.col(1).swap(m.F.col(2));
      return m;
    }
    fs *= 0.97;  // a slightly different size changes the whole Delaunay refinement
  }
  throw Error(what + ": the surface mesher did not produce a closed genus-0 manifold");
}

double creature_area_estimate(const Creature& cr) {
  // Sum of the parts' areas minus the overlapped caps (rough; corrected by one
  // calibration pass when far off).
  double area = 0;
  for (const Part& p : cr.parts) {
    if (p.ellipsoid) {
      const double pw = 1.6075, x = std::pow(p.e.x(), pw), y = std::pow(p.e.y(), pw), z = std::pow(p.e.z(), pw);
      area += 4 * M_PI * std::pow((x * y + x * z + y * z) / 3, 1 / pw);  // Knud Thomsen
    } else {
      area += 2 * M_PI * p.r * (p.b - p.a).norm() + 2 * M_PI * p.r * p.r;  // tube + the exposed cap
    }
  }
  return area;
}

}  // namespace

TriMesh make_creature(std::uint64_t seed, int target_vertices) {
  if (target_vertices < 500 || target_vertices > 200000)
    throw InputError("creature: vertex count must be in [500, 200000]");
  Creature cr = make_creature_skeleton(seed);
  double area = creature_area_estimate(cr);
  TriMesh m = mesh_with_retries(cr, area, target_vertices, seed, "creature");
  // One correction when far from the target: the true area of the union.
  double ratio = double(m.num_vertices()) / target_vertices;
  if (ratio < 0.85 || ratio > 1.15)
    m = mesh_with_retries(cr, area * m.num_vertices() / target_vertices, target_vertices, seed, "creature");
  return m;
}

Deformation creature_deformation(std::uint64_t seed, PairKind kind) {
  Creature cr = make_creature_skeleton(seed);
  Rng rng(mix(seed * 2 + 2) ^ (kind == PairKind::NonIsometric ? 0x5bd1e995ULL : 0));
  const int n = int(cr.parts.size());
  const Eigen::Vector3d X = Eigen::Vector3d::UnitX(), Y = Eigen::Vector3d::UnitY(),
                        Z = Eigen::Vector3d::UnitZ();
  // Local rotations (degrees) about each joint, in the rest frame.
  std::vector<Eigen::Matrix3d> local(n, Eigen::Matrix3d::Identity());
  local[Neck] = rot(Z, rng.uniform(-30, 30)) * rot(Y, rng.uniform(-20, 15));
  local[Head] = rot(Y, rng.uniform(-20, 20)) * rot(X, rng.uniform(-15, 15));
  local[Tail] = rot(Z, rng.uniform(-35, 35)) * rot(Y, rng.uniform(-20, 20));
  for (int k = 0; k < 4; ++k) {
    local[Thigh0 + k] = rot(Y, rng.uniform(-18, 18)) * rot(X, rng.uniform(-6, 6));
    local[Shin0 + k] = rot(Y, rng.uniform(-25, 12));
  }
  // Scalings (NonIsometric): body stretch, thicker legs, bigger head.
  std::vector<Eigen::Matrix3d> scale(n, Eigen::Matrix3d::Identity());
  if (kind == PairKind::NonIsometric) {
    scale[Body] = Eigen::Vector3d(rng.uniform(1.1, 1.3), rng.uniform(0.85, 1.05), rng.uniform(0.9, 1.1)).asDiagonal();
    double thick = rng.uniform(1.1, 1.3);
    for (int k = 0; k < 4; ++k)
      for (int part : {Thigh0 + k, Shin0 + k}) {
        Eigen::Vector3d ax = (cr.parts[part].b - cr.parts[part].a).normalized();
        scale[part] = Eigen::Matrix3d::Identity() + (thick - 1) * (Eigen::Matrix3d::Identity() - ax * ax.transpose());
      }
    scale[Head] *= rng.uniform(1.15, 1.4);
    Eigen::Vector3d nax = (cr.parts[Neck].b - cr.parts[Neck].a).normalized();
    scale[Neck] = Eigen::Matrix3d::Identity() + (rng.uniform(1.0, 1.2) - 1) * nax * nax.transpose();
  }
  // Affine map per part: x -> M_i x + t_i (parents come before children).
  std::vector<Eigen::Matrix3d> world_rot(n), M(n);
  std::vector<Eigen::Vector3d> t(n);
  for (int i = 0; i < n; ++i) {
    const Part& p = cr.parts[i];
    if (p.parent < 0) {
      world_rot[i] = Eigen::Matrix3d::Identity();
      M[i] = scale[i];
      t[i] = Eigen::Vector3d::Zero();
      continue;
    }
    world_rot[i] = world_rot[p.parent] * local[i];
    M[i] = world_rot[i] * scale[i];
    Eigen::Vector3d joint_image = M[p.parent] * p.joint + t[p.parent];
    t[i] = joint_image - M[i] * p.joint;
  }
  const double tau = 0.04;  // softmax width of the skinning weights (body length ~2)
  auto shared = std::make_shared<Creature>(std::move(cr));
  Deformation d;
  d.apply = [shared, M, t, tau](const Eigen::Vector3d& x) -> Eigen::Vector3d {
    const int n = int(shared->parts.size());
    double dist[NumParts];
    double dmin = 1e300;
    for (int i = 0; i < n; ++i) dmin = std::min(dmin, dist[i] = shared->parts[i].distance(x));
    Eigen::Vector3d y = Eigen::Vector3d::Zero();
    double wsum = 0;
    for (int i = 0; i < n; ++i) {
      double w = std::exp(-(dist[i] - dmin) / tau);
      if (w < 1e-12) continue;
      y += w * (M[i] * x + t[i]);
      wsum += w;
    }
    return y / wsum;
  };
  return d;
}

namespace {

Eigen::MatrixXd deform_points(const Deformation& d, const Eigen::MatrixXd& V) {
  Eigen::MatrixXd out(V.rows(), 3);
#pragma omp parallel for schedule(static)
  for (Eigen::Index i = 0; i < V.rows(); ++i) out.row(i) = d.apply(V.row(i).transpose()).transpose();
  return out;
}

BarycentricMap project(const Eigen::MatrixXd& P, const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) {
  ClosestPoint3 bvh(V, F);
  std::vector<ClosestPointResult> r = bvh.query(P);
  BarycentricMap m;
  m.elem.resize(P.rows());
  m.bary.resize(P.rows(), 3);
  for (Eigen::Index i = 0; i < P.rows(); ++i) {
    m.elem(i) = r[i].elem;
    m.bary.row(i) = r[i].bary.head<3>().transpose();
  }
  return m;
}

}  // namespace

GeneratedPair make_creature_pair(std::uint64_t seed, PairKind kind, int target_vertices) {
  GeneratedPair g;
  g.A = make_creature(seed, target_vertices);
  g.deformation = creature_deformation(seed, kind);
  TriMesh deformed{deform_points(g.deformation, g.A.V), g.A.F};
  // B: the deformed A remeshed by Mesh_3 on the polyhedral domain of deform(A), at a
  // size for about the same vertex count. Its vertices lie on deform(A), its
  // triangles are unrelated to A's.
  const double area = surface_area(deformed.V, deformed.F);
  double fs = std::sqrt(kDensity * area / target_vertices);
  bool ok = false;
  for (int attempt = 0; attempt < 6 && !ok; ++attempt) {
    g.B = cgal_internal::remesh_surface(deformed, fs, kDistanceRatio * fs,
                                        unsigned(mix(seed * 7 + 3 + attempt) & 0x7fffffff));
    ok = cgal_internal::surface_topology(g.B).genus0();
    fs *= 0.97;
  }
  if (!ok) throw Error("creature pair: remeshing the deformed creature did not give a genus-0 manifold");
  if (enclosed_volume(g.B.V, g.B.F) < 0) g.B.F.col(1).swap(g.B.F.col(2));
  g.truth_AB = project(deformed.V, g.B.V, g.B.F);
  g.truth_BA = project(g.B.V, deformed.V, deformed.F);
  return g;
}

}  // namespace shapemap

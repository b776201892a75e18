// Tetrahedralization of a closed surface (CGAL Mesh_3, polyhedral domain) and the
// polyhedral surface remesher used by the generated pairs. The Mesh_3 unit for polyhedral
// domains (implicit_mesher.cpp: implicit ones); tetrahedralize() itself, which first looks
// for self-intersections (CGAL PMP), is in self_intersections.cpp, so that the two long
// CGAL instantiations compile side by side.
#include "shapemap/volume/tetrahedralize.h"
#include "shapemap/geometry/tet_volume.h"
#include "internal.h"
#include "shapemap/checks.h"
#include "shapemap/error.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Mesh_complex_3_in_triangulation_3.h>
#include <CGAL/Mesh_criteria_3.h>
#include <CGAL/Mesh_error_code.h>
#include <CGAL/Mesh_triangulation_3.h>
#include <CGAL/Polyhedral_mesh_domain_with_features_3.h>
#include <CGAL/Random.h>
#include <CGAL/make_mesh_3.h>
#include <CGAL/refine_mesh_3.h>
#include "c3t3_surface.h"  // after the CGAL headers it instantiates
#include "surface_mesh.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <iomanip>
#include <iostream>
#include <memory>
#include <mutex>
#include <sstream>
#include <thread>
#include <unordered_map>

namespace shapemap {
namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = K::Point_3;
using cgal_internal::SurfaceMesh;
using cgal_internal::to_surface_mesh;
using Domain = CGAL::Polyhedral_mesh_domain_with_features_3<K, SurfaceMesh>;
using Tr = CGAL::Mesh_triangulation_3<Domain, CGAL::Default, CGAL::Sequential_tag>::type;
using C3t3 = CGAL::Mesh_complex_3_in_triangulation_3<Tr, Domain::Corner_index, Domain::Curve_index>;
using Criteria = CGAL::Mesh_criteria_3<Tr>;
using Vertex_handle = Tr::Vertex_handle;
}  // namespace
}  // namespace shapemap
SHAPEMAP_NO_C3T3_DUMP(shapemap::C3t3)
namespace shapemap {
namespace {


// Initial surface points for Mesh_3: input vertices taken at a stride over the index
// range, keeping only those at least min_separation from the ones already kept (close
// initial points make the Delaunay refinement cascade around them), each snapped to
// the surface by a short segment across it along the vertex normal (which also gives
// the Mesh_3 surface index). Every part of the surface gets points, so thin parts
// (legs, ears) cannot be missed by the random ray shooting of CGAL's default
// initialization.
void insert_initial_points(C3t3& c3t3, const Domain& domain, const TriMesh& m, int count,
                           double min_separation) {
  Eigen::MatrixXd N = vertex_normals(m.V, m.F);
  const double diag = bbox_diagonal(m.V);
  double eps = 1e-4 * diag;
  auto intersect = domain.construct_intersection_object();
  auto cwp = c3t3.triangulation().geom_traits().construct_weighted_point_3_object();
  const int n = m.num_vertices();
  count = std::clamp(count, 4, n);
  std::vector<Eigen::Vector3d> kept;
  for (int k = 0; k < count; ++k) {
    int i = int((long long)k * n / count);
    Eigen::Vector3d p = m.V.row(i), d = N.row(i);
    bool close = false;
    for (const Eigen::Vector3d& q : kept) close |= (q - p).norm() < min_separation;
    if (close) continue;
    K::Segment_3 s(Point(p.x() - eps * d.x(), p.y() - eps * d.y(), p.z() - eps * d.z()),
                   Point(p.x() + eps * d.x(), p.y() + eps * d.y(), p.z() + eps * d.z()));
    Domain::Intersection in = intersect(s);
    if (std::get<2>(in) == 0) continue;  // no crossing (degenerate normal)
    Vertex_handle v = c3t3.triangulation().insert(cwp(std::get<0>(in)));
    if (v != Vertex_handle()) {
      c3t3.set_dimension(v, 2);
      c3t3.set_index(v, std::get<1>(in));
      kept.push_back(p);
    }
  }
}

Eigen::Vector3d to_eigen(const Point& p) { return {p.x(), p.y(), p.z()}; }


// Sets `stop` after `seconds` unless destroyed first (Mesh_3 polls it between steps).
class Watchdog {
 public:
  explicit Watchdog(double seconds)
      : thread_([this, seconds] {
          std::unique_lock<std::mutex> lock(mutex_);
          if (!cv_.wait_for(lock, std::chrono::duration<double>(seconds), [this] { return done_; }))
            stop = true;
        }) {}
  ~Watchdog() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      done_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }
  std::atomic<bool> stop{false};

 private:
  std::mutex mutex_;
  std::condition_variable cv_;
  bool done_ = false;
  std::thread thread_;
};

}  // namespace

namespace {

// Redirects std::cerr to a buffer while alive (single-threaded meshing code only).
class CerrSilencer {
 public:
  CerrSilencer() : old_(std::cerr.rdbuf(sink_.rdbuf())) {}
  ~CerrSilencer() { std::cerr.rdbuf(old_); }
  CerrSilencer(const CerrSilencer&) = delete;
  CerrSilencer& operator=(const CerrSilencer&) = delete;

 private:
  std::ostringstream sink_;
  std::streambuf* old_;
};

void require_valid_options(const TetrahedralizeOptions& opt) {
  if (opt.edge_length < 0) throw InputError("tetrahedralize: edge length must be positive");
  if (opt.target_tets < 0) throw InputError("tetrahedralize: target tet count must be positive");
  if (opt.target_tets > kMaxTetrahedralizeTets)
    throw InputError("tetrahedralize: target tet count " + std::to_string(opt.target_tets) + " is more than " +
                     std::to_string(kMaxTetrahedralizeTets));
  if (!(opt.radius_edge_ratio >= 2)) throw InputError("tetrahedralize: radius-edge ratio must be >= 2");
}

// Target edge length L (opt.edge_length, or from opt.target_tets: a regular tet of edge a has
// volume a^3 / (6 sqrt 2); Delaunay refinement stops below the size bound, so the mean tet is
// smaller than the bound by a factor kTetFill, calibrated on spheres and spot.obj) for a
// surface enclosing vol with bounding-box diagonal diag; expected_tets: the tets it gives.
double tet_edge_length(const TetrahedralizeOptions& opt, double vol, double diag, double& expected_tets) {
  constexpr double kTetFill = 2.65;
  double L = opt.edge_length;
  if (L <= 0) {
    int n = opt.target_tets > 0 ? opt.target_tets : 30000;
    L = std::cbrt(6 * std::sqrt(2.0) * vol * kTetFill / n);
  }
  if (!(L > 1e-6 * diag)) throw InputError("tetrahedralize: edge length too small for the input size");
  expected_tets = 6 * std::sqrt(2.0) * vol * kTetFill / (L * L * L);
  if (expected_tets > kMaxTetrahedralizeTets) {
    std::ostringstream m;
    m << "tetrahedralize: edge length " << L << " gives about " << std::setprecision(2) << expected_tets
      << " tets, more than " << kMaxTetrahedralizeTets;
    throw InputError(m.str());
  }
  return L;
}

// Vertices of `m` at the position of another vertex: where the surface touches itself
// (repair_surface() splits a non-manifold edge or vertex into copies at one position).
int touching_vertices(const TriMesh& m) {
  std::vector<int> order(m.V.rows());
  for (int i = 0; i < int(order.size()); ++i) order[i] = i;
  auto key = [&](int i) { return std::array<double, 3>{m.V(i, 0), m.V(i, 1), m.V(i, 2)}; };
  std::sort(order.begin(), order.end(), [&](int a, int b) { return key(a) < key(b); });
  int n = 0;
  for (size_t k = 0; k < order.size(); ++k)
    if ((k > 0 && key(order[k]) == key(order[k - 1])) || (k + 1 < order.size() && key(order[k]) == key(order[k + 1])))
      ++n;
  return n;
}

// The cells of the complex on compacted vertices, positively oriented.
TetMesh extract_tets(const C3t3& c3t3, const std::string& name) {
  std::unordered_map<Vertex_handle, int> index;
  std::vector<Eigen::Vector3d> pts;
  std::vector<std::array<int, 4>> tets;
  tets.reserve(c3t3.number_of_cells_in_complex());
  for (auto c = c3t3.cells_in_complex_begin(); c != c3t3.cells_in_complex_end(); ++c) {
    std::array<int, 4> t;
    for (int j = 0; j < 4; ++j) {
      Vertex_handle v = c->vertex(j);
      auto [it, inserted] = index.emplace(v, int(pts.size()));
      if (inserted) pts.push_back(to_eigen(v->point().point()));
      t[j] = it->second;
    }
    tets.push_back(t);
  }
  if (tets.empty())
    throw InputError(name + ": no tetrahedra at this size (too few tets asked for this surface; ask for more)");
  TetMesh out;
  out.V.resize(pts.size(), 3);
  for (size_t i = 0; i < pts.size(); ++i) out.V.row(i) = pts[i].transpose();
  out.T.resize(tets.size(), 4);
  for (size_t t = 0; t < tets.size(); ++t) {
    auto& q = tets[t];
    Eigen::Vector3d a = pts[q[0]], b = pts[q[1]], c = pts[q[2]], d = pts[q[3]];
    if (signed_tet_volume6(a, b, c, d) < 0) std::swap(q[2], q[3]);
    out.T.row(t) << q[0], q[1], q[2], q[3];
  }
  return out;
}

namespace P = CGAL::parameters;
// The optimization steps' parameter types (one type whether a step is on or off).
using Perturb = decltype(P::no_perturb());
using Exude = decltype(P::no_exude());
using Odt = decltype(P::no_odt());

// What the Mesh_3 calls of one tetrahedralization share: the surface, the criteria, the
// optimization steps and the runaway guard, which reports into `error`.
struct MeshRun {
  const TriMesh& surface;
  unsigned seed = 0;
  double L = 0, area = 0;
  std::size_t max_vertices = 0;
  Criteria criteria;
  Perturb perturb;
  Exude exude;
  Odt odt;
  CGAL::Mesh_error_code error = CGAL::CGAL_MESH_3_NO_ERROR;
  P::internal::Mesh_3_options guard;
};

// The crease-protected meshing (creases sharper than 120 deg dihedral as 1D features);
// false, with the reason in info, when CGAL's protection fails or the meshing hits the
// vertex cap or the wall-clock budget: the plain meshing takes over.
bool mesh_with_creases(MeshRun& r, Domain& domain, C3t3& c3t3, double time_limit, TetrahedralizeInfo* info) {
  // CGAL's checks are on in this library (CMakeLists.txt): a failure of the crease
  // protection is an exception.
  try {
    // Some noisy surfaces make the protected refinement crawl without adding vertices
    // (measured: a perturbed icosphere, > 300 s): a wall-clock budget, after which the
    // plain meshing takes over. Only such inputs depend on the machine's speed.
    Watchdog watchdog(time_limit > 0 ? time_limit : 1e9);
    r.guard.pointer_to_stop_atomic_boolean = &watchdog.stop;
    c3t3 = CGAL::make_mesh_3<C3t3>(domain, r.criteria, P::features(domain), r.perturb, r.exude, r.odt,
                                   P::no_lloyd(), P::manifold(), r.guard);
    r.guard.pointer_to_stop_atomic_boolean = nullptr;
    if (r.error == CGAL::CGAL_MESH_3_NO_ERROR) {
      if (info) info->creases_protected = true;
      return true;
    }
    if (info)
      info->creases_dropped = r.error == CGAL::CGAL_MESH_3_STOPPED
                                  ? "took over " + std::to_string(int(time_limit)) + " s"
                                  : "more than " + std::to_string(r.max_vertices) + " vertices";
  } catch (const CGAL::Failure_exception& e) {
    r.guard.pointer_to_stop_atomic_boolean = nullptr;
    if (info)
      info->creases_dropped = (e.expression().empty() ? std::string("a check") : e.expression()) + " in " +
                              e.filename().substr(e.filename().find_last_of('/') + 1);
  }
  return false;
}

// Plain meshing (no protected creases) on a fresh domain and a fresh random state, with or
// without Mesh_3's manifold criterion; true when it converged under the vertex cap.
bool mesh_plain(MeshRun& r, bool manifold, C3t3& c3t3) {
  r.error = CGAL::CGAL_MESH_3_NO_ERROR;
  c3t3 = C3t3();
  CGAL::get_default_random() = CGAL::Random(r.seed);
  CGAL::Random rng(r.seed);
  const SurfaceMesh sm = to_surface_mesh(r.surface, "surface");  // outlives its domain
  Domain domain(sm, &rng);
  const int npts = int(std::clamp(r.area / (r.L * r.L) / 8, 20.0, 400.0));
  insert_initial_points(c3t3, domain, r.surface, npts, 1.5 * r.L);
  if (manifold)
    CGAL::refine_mesh_3(c3t3, domain, r.criteria, r.perturb, r.exude, r.odt, P::no_lloyd(), P::no_reset_c3t3(),
                        P::manifold(), r.guard);
  else
    CGAL::refine_mesh_3(c3t3, domain, r.criteria, r.perturb, r.exude, r.odt, P::no_lloyd(), P::no_reset_c3t3(),
                        P::non_manifold(), r.guard);
  return r.error == CGAL::CGAL_MESH_3_NO_ERROR;
}

// The plain meshing with Mesh_3's manifold criterion unless the surface touches itself, and
// without it when that runs away (over the vertex cap, or a CGAL check): a surface that
// touches itself other than at shared vertex positions (two sheets a hair apart) runs away
// the same way. Throws when the meshing without the criterion does not converge either.
void mesh_plain_with_fallback(MeshRun& r, int touching, C3t3& c3t3, const std::string& name,
                              TetrahedralizeInfo* info) {
  bool ok = false;
  if (touching == 0) {
    std::string why = "more than " + std::to_string(r.max_vertices) + " vertices";
    try {
      ok = mesh_plain(r, true, c3t3);
    } catch (const CGAL::Failure_exception& e) {
      why = "CGAL failed: " + e.expression();
    }
    if (!ok && info) info->manifold_dropped = why;
  }
  if (!ok) {
    try {
      ok = mesh_plain(r, false, c3t3);
    } catch (const CGAL::Failure_exception& e) {
      throw Error("tetrahedralize: CGAL Mesh_3 failed (" + e.expression() + ")");
    }
  }
  if (!ok)
    throw InputError(name + ": Mesh_3 refinement did not converge (over " + std::to_string(r.max_vertices) +
                     " vertices); the surface is too noisy or too thin for this tet size");
}

// One Mesh_3 run on a closed surface: the criteria from the edge length, the optimization
// steps, the runaway guard, then the crease-protected meshing with the plain meshing as its
// fallback.
TetMesh mesh_once(const TriMesh& surface_in, const TetrahedralizeOptions& opt,
                  const ProgressCallback& progress, TetrahedralizeInfo* info) {
  if (info) *info = TetrahedralizeInfo{};
  const std::string name = "surface";
  cgal_internal::require_closed_manifold(surface_in, name);
  require_valid_options(opt);
  TriMesh surface = surface_in;
  double vol = enclosed_volume(surface.V, surface.F);
  if (vol < 0) {
    surface.F.col(1).swap(surface.F.col(2));
    vol = -vol;
  }
  const double diag = bbox_diagonal(surface.V);
  if (!(vol > 1e-12 * diag * diag * diag)) throw InputError(name + ": encloses no volume");

  double expected_tets = 0;
  const double L = tet_edge_length(opt, vol, diag, expected_tets);

  report(progress, "tetrahedralize/setup", 0);
  // Mesh_3 writes warnings and "refinement can't start" banners to std::cerr; the
  // library never prints (failures become exceptions below), so they are dropped.
  const CerrSilencer silence;
  CGAL::get_default_random() = CGAL::Random(opt.seed);

  // Criteria (CGAL Mesh_3 user manual, section 2.3): circumradius bounds derived from L:
  // a regular tet of edge L has circumradius 0.61 L, an equilateral triangle 0.58 L.
  // facet_distance tied to L: a much finer surface than volume makes sliver
  // perturbation slow (measured on spot.obj); capped at 1% of the bounding box.
  const double facet_distance = std::min(0.1 * L, 0.01 * diag);
  // An explicit time limit (0 = none): CGAL's default limit is the refinement time,
  // which would make the result depend on the machine load.
  const double tl = std::max(0.0, opt.optimize_time_limit);
  MeshRun run{surface,
              opt.seed,
              L,
              surface_area(surface.V, surface.F),
              // Runaway guard (deterministic): on noisy surfaces Mesh_3 can refine around tiny
              // crease features without end (measured: a randomly perturbed icosphere ran >
              // 200 s). A cap of twice the expected tet count in vertices (~10x the expected
              // vertex count).
              std::size_t(std::max(20000.0, 2 * expected_tets)),
              Criteria(P::edge_size = L, P::facet_angle = 25, P::facet_size = 0.58 * L,
                       P::facet_distance = facet_distance, P::cell_radius_edge_ratio = opt.radius_edge_ratio,
                       P::cell_size = 0.61 * L),
              opt.optimize ? P::perturb(P::time_limit = tl, P::sliver_bound = opt.sliver_bound) : P::no_perturb(),
              opt.optimize ? P::exude(P::time_limit = tl, P::sliver_bound = opt.sliver_bound) : P::no_exude(),
              // ODT smoothing (Tournois, Wormser, Alliez, Desbrun 2009) before the sliver steps: on
              // spot.obj and creatures it lowers the ball map's mean D_V by 15-19% at the same
              // vertex count (docs/methods.md, "Tetrahedralization"); 10 iterations, CGAL's test.
              opt.optimize && opt.odt ? P::odt(P::time_limit = tl, P::max_iteration_number = 10) : P::no_odt()};
  run.guard.maximal_number_of_vertices = run.max_vertices;
  run.guard.pointer_to_error_code = &run.error;
  report(progress, "tetrahedralize/refine", 0);

  // Where the surface touches itself no surface mesh of the region is manifold, and Mesh_3's
  // manifold criterion refines there without end (a real camel pose: over 60k vertices, or a
  // CGAL failure). Such surfaces are meshed without the criterion and without crease
  // protection, whose meshing uses it.
  const int touching = touching_vertices(surface);
  if (info) info->touching_vertices = touching;
  C3t3 c3t3;
  bool meshed = false;
  if (opt.faithful_boundary && touching == 0) {
    CGAL::Random rng(opt.seed);
    const SurfaceMesh sm = to_surface_mesh(surface, name);
    Domain domain(sm, &rng);
    domain.detect_features(60);  // protect creases sharper than 120 deg dihedral
    if (domain.maximal_curve_index() != Domain::Curve_index())
      meshed = mesh_with_creases(run, domain, c3t3, opt.crease_time_limit, info);
  }
  if (!meshed) mesh_plain_with_fallback(run, touching, c3t3, name, info);
  report(progress, "tetrahedralize/refine", 1);

  TetMesh out = extract_tets(c3t3, name);
  report(progress, "tetrahedralize/extract", 1);
  return out;
}

}  // namespace

TetMesh keep_odt_unless_defective(TetMesh smoothed,
                                  const std::function<TetMesh(TetrahedralizeInfo*)>& remesh_plain,
                                  TetrahedralizeInfo* info) {
  // Seen on shrec07-302.off: ODT left a non-manifold edge on the boundary. Deterministic: the
  // same input gives the same choice.
  auto defects = [](const MeshReport& r) {
    return r.non_manifold_edges + r.non_manifold_vertices + r.degenerate_elements + r.inverted_elements;
  };
  const MeshReport rep = check_volume(smoothed);
  if (defects(rep) > 0) {
    TetrahedralizeInfo plain_info;
    TetMesh alt = remesh_plain(&plain_info);
    if (defects(check_volume(alt)) < defects(rep)) {
      plain_info.odt_smoothed = false;
      plain_info.odt_dropped = rep.problems.empty() ? "defective tets" : rep.problems.front();
      if (info) *info = plain_info;
      return alt;
    }
  }
  if (info) info->odt_smoothed = true;
  return smoothed;
}

// One meshing of `surface` (crossings: its count of crossing face pairs, for info); called by
// tetrahedralize() (self_intersections.cpp).
TetMesh tetrahedralize_once(const TriMesh& surface, const TetrahedralizeOptions& opt,
                            const ProgressCallback& progress, TetrahedralizeInfo* info,
                            int crossings) {
  // A surface that crosses itself (real scans often do, locally: shrec07-302.off has 998
  // crossing pairs by this count) still bounds a region by ray parity, which the polyhedral domain meshes.
  // Crease detection along the crossing curves is what crawled (a sphere with a vertex pushed
  // through the far side: the crease protection ran to its 60 s budget), so it is skipped.
  TetrahedralizeOptions o = opt;
  if (crossings > 0) o.faithful_boundary = false;
  TetMesh out = mesh_once(surface, o, progress, info);
  if (info) info->self_intersecting_pairs = crossings;
  if (!(o.optimize && o.odt)) return out;
  TetrahedralizeOptions plain = o;
  plain.odt = false;
  auto remesh_plain = [&](TetrahedralizeInfo* plain_info) {
    TetMesh m = mesh_once(surface, plain, progress, plain_info);
    if (plain_info) plain_info->self_intersecting_pairs = crossings;
    return m;
  };
  return keep_odt_unless_defective(std::move(out), remesh_plain, info);
}

namespace cgal_internal {

TriMesh remesh_surface(const TriMesh& surface, double facet_size, double facet_distance,
                       unsigned seed) {
  require_closed_manifold(surface, "surface");
  CGAL::get_default_random() = CGAL::Random(seed);
  SurfaceMesh sm = to_surface_mesh(surface, "surface");
  CGAL::Random rng(seed);
  Domain domain(sm, &rng);
  namespace P = CGAL::parameters;
  Criteria criteria(P::facet_angle = 25, P::facet_size = facet_size,
                    P::facet_distance = facet_distance);
  C3t3 c3t3;
  double area = surface_area(surface.V, surface.F);
  int npts = int(std::clamp(area / (facet_size * facet_size) / 16, 20.0, 400.0));
  insert_initial_points(c3t3, domain, surface, npts, 2.5 * facet_size);
  CGAL::refine_mesh_3(c3t3, domain, criteria, P::no_perturb(), P::no_exude(), P::no_odt(),
                      P::no_lloyd(), P::no_reset_c3t3(), P::manifold());

  return complex_boundary_surface(c3t3);
}

}  // namespace cgal_internal
}  // namespace shapemap

// Validity reports of surfaces and tet meshes, and the input guards of the methods.
#include "shapemap/checks.h"
#include "shapemap/geometry/tet_volume.h"
#include "shapemap/adjacency.h"
#include "shapemap/error.h"
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numeric>

namespace shapemap {

namespace {

// Relative threshold below which an element counts as degenerate: |cross| <= eps *
// (longest edge)^2 for triangles, |6 vol| <= eps * (longest edge)^3 for tets.
constexpr double kDegenerateEps = 1e-12;

int count_unreferenced(const Eigen::MatrixXi& E, int n, std::vector<char>* used_out = nullptr) {
  std::vector<char> used(size_t(n), 0);
  for (Eigen::Index i = 0; i < E.size(); ++i) used[size_t(E.data()[i])] = 1;
  int c = int(std::count(used.begin(), used.end(), 0));
  if (used_out) *used_out = std::move(used);
  return c;
}

// Vertices at exactly the same position as another vertex (counted once per extra copy).
int count_duplicates(const Eigen::MatrixXd& V) {
  std::vector<int> idx(size_t(V.rows()));
  std::iota(idx.begin(), idx.end(), 0);
  auto less = [&](int a, int b) {
    for (int j = 0; j < 3; ++j)
      if (V(a, j) != V(b, j)) return V(a, j) < V(b, j);
    return false;
  };
  std::sort(idx.begin(), idx.end(), less);
  int d = 0;
  for (size_t i = 1; i < idx.size(); ++i)
    if (!less(idx[i - 1], idx[i])) ++d;
  return d;
}

// Number of components among vertices referenced by the elements.
int count_components(const Eigen::MatrixXi& E, int n, const std::vector<char>& used) {
  int nc = 0;
  Eigen::VectorXi comp = connected_components(E, n, &nc);
  std::vector<char> seen(size_t(nc), 0);
  int c = 0;
  for (int v = 0; v < n; ++v)
    if (used[size_t(v)] && !seen[size_t(comp(v))]) {
      seen[size_t(comp(v))] = 1;
      ++c;
    }
  return c;
}

// Edge topology of a triangle mesh whose faces have three distinct indices.
struct EdgeTopology {
  Eigen::MatrixXi E, FE;       // unique edges, face -> edge opposite each corner
  std::vector<int> count;      // faces per edge
  std::vector<int> direction;  // sum over incident faces of +1 (traversed low->high) / -1
};

EdgeTopology edge_topology(const Eigen::MatrixXi& F) {
  EdgeTopology t;
  t.E = unique_edges(F, &t.FE);
  t.count.assign(size_t(t.E.rows()), 0);
  t.direction.assign(size_t(t.E.rows()), 0);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      int e = t.FE(f, c);
      ++t.count[size_t(e)];
      t.direction[size_t(e)] += F(f, (c + 1) % 3) < F(f, (c + 2) % 3) ? 1 : -1;
    }
  return t;
}

// Consistent orientation by breadth-first propagation across manifold edges. flip[f]
// says whether face f must be reversed (the first face of each component is kept).
// Returns false if some component is not orientable.
bool consistent_flips(const Eigen::MatrixXi& F, const EdgeTopology& t, std::vector<char>* flip) {
  const Eigen::Index m = std::max<Eigen::Index>(F.rows(), 0);
  // Faces around each manifold edge.
  std::vector<std::array<int, 4>> ef(size_t(t.E.rows()), {-1, -1, -1, -1});
  for (Eigen::Index f = 0; f < m; ++f)
    for (int c = 0; c < 3; ++c) {
      auto& a = ef[size_t(t.FE(f, c))];
      if (a[0] < 0) a[0] = int(f), a[1] = c;
      else if (a[2] < 0) a[2] = int(f), a[3] = c;
    }
  flip->assign(size_t(m), 0);
  std::vector<char> done(size_t(m), 0);
  std::vector<int> queue;
  bool orientable = true;
  for (Eigen::Index s = 0; s < m; ++s) {
    if (done[size_t(s)]) continue;
    done[size_t(s)] = 1;
    queue.assign(1, int(s));
    for (size_t q = 0; q < queue.size(); ++q) {
      int f = queue[q];
      for (int c = 0; c < 3; ++c) {
        int e = t.FE(f, c);
        if (t.count[size_t(e)] != 2) continue;
        const auto& a = ef[size_t(e)];
        int g = a[0] == f ? a[2] : a[0], cg = a[0] == f ? a[3] : a[1];
        if (g < 0 || g == f) continue;
        bool same_dir = F(f, (c + 1) % 3) == F(g, (cg + 1) % 3);  // same traversal of the edge
        char want = char(same_dir ? !(*flip)[size_t(f)] : (*flip)[size_t(f)]);
        if (!done[size_t(g)]) {
          done[size_t(g)] = 1;
          (*flip)[size_t(g)] = want;
          queue.push_back(g);
        } else if ((*flip)[size_t(g)] != want) {
          orientable = false;
        }
      }
    }
  }
  return orientable;
}

// Vertices whose link is not a single path or cycle.
int count_non_manifold_vertices(const Eigen::MatrixXi& F, int n) {
  std::vector<std::vector<int>> inc = vertex_elements(F, n);
  int bad = 0;
  std::vector<int> nb, deg, parent;
  for (int v = 0; v < n; ++v) {
    if (inc[size_t(v)].empty()) continue;
    nb.clear();
    for (int f : inc[size_t(v)])
      for (int j = 0; j < 3; ++j)
        if (F(f, j) != v) nb.push_back(F(f, j));
    std::sort(nb.begin(), nb.end());
    nb.erase(std::unique(nb.begin(), nb.end()), nb.end());
    deg.assign(nb.size(), 0);
    parent.resize(nb.size());
    std::iota(parent.begin(), parent.end(), 0);
    auto find = [&](int x) {
      while (parent[size_t(x)] != x) x = parent[size_t(x)] = parent[size_t(parent[size_t(x)])];
      return x;
    };
    auto local = [&](int u) { return int(std::lower_bound(nb.begin(), nb.end(), u) - nb.begin()); };
    bool ok = true;
    for (int f : inc[size_t(v)]) {
      int a = -1, b = -1;
      for (int j = 0; j < 3; ++j)
        if (F(f, j) != v) (a < 0 ? a : b) = F(f, j);
      int la = local(a), lb = local(b);
      if (++deg[size_t(la)] > 2 || ++deg[size_t(lb)] > 2) ok = false;
      int ra = find(la), rb = find(lb);
      if (ra != rb) parent[size_t(std::max(ra, rb))] = std::min(ra, rb);
    }
    if (ok) {
      int roots = 0;
      for (size_t i = 0; i < nb.size(); ++i)
        if (find(int(i)) == int(i)) ++roots;
      ok = roots == 1;
    }
    if (!ok) ++bad;
  }
  return bad;
}

// Faces with three distinct indices (the others take no part in the topology).
Eigen::MatrixXi topological_faces(const Eigen::MatrixXi& F, std::vector<int>* rows = nullptr) {
  std::vector<int> keep;
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    if (F(f, 0) != F(f, 1) && F(f, 1) != F(f, 2) && F(f, 0) != F(f, 2)) keep.push_back(int(f));
  Eigen::MatrixXi G(Eigen::Index(keep.size()), 3);
  for (size_t i = 0; i < keep.size(); ++i) G.row(Eigen::Index(i)) = F.row(keep[i]);
  if (rows) *rows = std::move(keep);
  return G;
}

int count_boundary_loops(const EdgeTopology& t, int n) {
  std::vector<int> parent(static_cast<size_t>(n));
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int x) {
    while (parent[size_t(x)] != x) x = parent[size_t(x)] = parent[size_t(parent[size_t(x)])];
    return x;
  };
  std::vector<char> on(size_t(n), 0);
  for (Eigen::Index e = 0; e < t.E.rows(); ++e)
    if (t.count[size_t(e)] == 1) {
      int a = find(t.E(e, 0)), b = find(t.E(e, 1));
      on[size_t(t.E(e, 0))] = on[size_t(t.E(e, 1))] = 1;
      if (a != b) parent[size_t(std::max(a, b))] = std::min(a, b);
    }
  int loops = 0;
  for (int v = 0; v < n; ++v)
    if (on[size_t(v)] && find(v) == v) ++loops;
  return loops;
}

// The checks surfaces and volumes share: matrix shapes, finite coordinates, indices in range;
// then the counts of unreferenced vertices (`used` marks the others) and duplicate vertices.
// False: the element loops cannot run.
bool check_common(MeshReport& R, const Eigen::MatrixXd& V, const Eigen::MatrixXi& E, int arity,
                  const char* elements, std::vector<char>& used) {
  R.num_vertices = int(V.rows());
  R.num_elements = int(E.rows());
  if (V.cols() != 3 || E.cols() != arity) {
    R.problems.push_back("vertex matrix has " + std::to_string(V.cols()) + " columns, element matrix " +
                         std::to_string(E.cols()) + " (need 3 and " + std::to_string(arity) + ")");
    R.indices_in_range = false;
    return false;
  }
  R.finite = V.allFinite();
  if (!R.finite) R.problems.push_back("non-finite (NaN or Inf) vertex coordinates");
  R.indices_in_range = E.size() == 0 || (E.minCoeff() >= 0 && E.maxCoeff() < V.rows());
  if (!R.indices_in_range) {
    R.problems.push_back(std::string(elements) + " indices out of range");
    return false;
  }
  if (E.rows() == 0) R.problems.push_back(std::string("no ") + elements);
  R.unreferenced_vertices = count_unreferenced(E, int(V.rows()), &used);
  if (R.finite) R.duplicate_vertices = count_duplicates(V);
  return true;
}

}  // namespace

std::string plural(long long n, const std::string& one, const std::string& many) {
  return std::to_string(n) + " " + (n == 1 ? one : many);
}

void append_repairable_problems(const MeshReport& R, std::vector<std::string>& P) {
  if (R.duplicate_vertices)
    P.push_back(plural(R.duplicate_vertices, "duplicate vertex", "duplicate vertices") + " (identical positions)");
  if (R.degenerate_elements)
    P.push_back(plural(R.degenerate_elements, "degenerate face", "degenerate faces") + " (zero area or repeated vertex)");
  if (R.non_manifold_edges)
    P.push_back(plural(R.non_manifold_edges, "non-manifold edge", "non-manifold edges") + " (more than 2 faces)");
  if (R.non_manifold_vertices) P.push_back(plural(R.non_manifold_vertices, "non-manifold vertex", "non-manifold vertices"));
}

MeshReport check_surface(const TriMesh& mesh) {
  MeshReport R;
  std::vector<char> used;
  if (!check_common(R, mesh.V, mesh.F, 3, "faces", used)) return R;
  const Eigen::MatrixXd& V = mesh.V;
  const Eigen::MatrixXi& F = mesh.F;
  const int n = int(V.rows());
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    int a = F(f, 0), b = F(f, 1), c = F(f, 2);
    bool degenerate = a == b || b == c || a == c;
    if (!degenerate && R.finite) {
      Eigen::Vector3d p = V.row(a), q = V.row(b), r = V.row(c);
      double l = std::max({(q - p).squaredNorm(), (r - q).squaredNorm(), (p - r).squaredNorm()});
      degenerate = (q - p).cross(r - p).norm() <= kDegenerateEps * l;
    }
    if (degenerate) ++R.degenerate_elements;
  }
  const Eigen::MatrixXi G = topological_faces(F);
  EdgeTopology t = edge_topology(G);
  for (size_t e = 0; e < t.count.size(); ++e) {
    if (t.count[e] > 2) ++R.non_manifold_edges;
    if (t.count[e] == 1) ++R.boundary_edges;
    if (t.count[e] == 2 && t.direction[e] != 0) R.consistently_oriented = false;
  }
  R.non_manifold_vertices = count_non_manifold_vertices(G, n);
  R.closed = F.rows() > 0 && R.boundary_edges == 0;
  R.components = count_components(F, n, used);
  R.boundary_components = count_boundary_loops(t, n);
  std::vector<char> used_top;
  int unref_top = count_unreferenced(G, n, &used_top);
  R.euler_characteristic = (n - unref_top) - int(t.E.rows()) + int(G.rows());
  std::vector<char> flips;
  bool orientable = consistent_flips(G, t, &flips);
  if (R.closed && R.components == 1 && R.non_manifold_edges == 0 && R.non_manifold_vertices == 0 && orientable &&
      G.rows() == F.rows() && R.euler_characteristic % 2 == 0)
    R.genus = (2 - R.euler_characteristic) / 2;

  auto& P = R.problems;
  if (R.unreferenced_vertices) P.push_back(plural(R.unreferenced_vertices, "unreferenced vertex", "unreferenced vertices"));
  append_repairable_problems(R, P);
  if (F.rows() > 0 && !R.closed)
    P.push_back("not closed: " + plural(R.boundary_edges, "boundary edge", "boundary edges") + " in " +
                plural(R.boundary_components, "hole", "holes"));
  if (!orientable) P.push_back("not orientable");
  else if (!R.consistently_oriented) P.push_back("faces not consistently oriented");
  if (R.components > 1) P.push_back(std::to_string(R.components) + " connected components");
  return R;
}

MeshReport check_volume(const TetMesh& mesh) {
  MeshReport R;
  std::vector<char> used;
  if (!check_common(R, mesh.V, mesh.T, 4, "tetrahedra", used)) return R;
  const Eigen::MatrixXd& V = mesh.V;
  const Eigen::MatrixXi& T = mesh.T;
  const int n = int(V.rows());
  bool repeated_any = false;
  for (Eigen::Index t = 0; t < T.rows(); ++t) {
    bool repeated = false;
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j) repeated |= T(t, i) == T(t, j);
    repeated_any |= repeated;
    bool degenerate = repeated;
    double vol6 = 0;
    if (!repeated && R.finite) {
      Eigen::Vector3d a = V.row(T(t, 0)), b = V.row(T(t, 1)), c = V.row(T(t, 2)), d = V.row(T(t, 3));
      vol6 = signed_tet_volume6(a, b, c, d);
      double l = std::sqrt(std::max({(b - a).squaredNorm(), (c - a).squaredNorm(), (d - a).squaredNorm(),
                                     (c - b).squaredNorm(), (d - b).squaredNorm(), (d - c).squaredNorm()}));
      degenerate = std::abs(vol6) <= kDegenerateEps * l * l * l;
    }
    if (degenerate) ++R.degenerate_elements;
    else if (vol6 < 0) ++R.inverted_elements;
  }
  // Faces shared by more than two tets, and repeated tets.
  int crowded_faces = 0, duplicate_tets = 0;
  {
    std::vector<std::array<int, 4>> keys(size_t(T.rows()));
    std::vector<std::array<int, 3>> faces;
    faces.reserve(size_t(T.rows()) * 4);
    for (Eigen::Index t = 0; t < T.rows(); ++t) {
      std::array<int, 4> k = {T(t, 0), T(t, 1), T(t, 2), T(t, 3)};
      std::sort(k.begin(), k.end());
      keys[size_t(t)] = k;
      faces.push_back({k[1], k[2], k[3]});
      faces.push_back({k[0], k[2], k[3]});
      faces.push_back({k[0], k[1], k[3]});
      faces.push_back({k[0], k[1], k[2]});
    }
    std::sort(keys.begin(), keys.end());
    for (size_t i = 1; i < keys.size(); ++i)
      if (keys[i] == keys[i - 1]) ++duplicate_tets;
    std::sort(faces.begin(), faces.end());
    for (size_t i = 0; i < faces.size();) {
      size_t j = i;
      while (j < faces.size() && faces[j] == faces[i]) ++j;
      if (j - i > 2) ++crowded_faces;
      i = j;
    }
  }
  R.components = count_components(T, n, used);
  R.consistently_oriented = R.inverted_elements == 0;
  if (T.rows() > 0) {
    TetBoundary b = boundary_surface(mesh);
    MeshReport s = check_surface(b.surface);
    R.non_manifold_edges = s.non_manifold_edges;
    R.non_manifold_vertices = s.non_manifold_vertices;
    R.boundary_edges = s.boundary_edges;
    R.closed = s.closed;
    R.euler_characteristic = s.euler_characteristic;
    R.genus = s.genus;
    R.boundary_components = s.components;
  }
  auto& P = R.problems;
  if (R.unreferenced_vertices)
    P.push_back(plural(R.unreferenced_vertices, "vertex", "vertices") + " used by no tetrahedron");
  if (R.duplicate_vertices)
    P.push_back(plural(R.duplicate_vertices, "duplicate vertex", "duplicate vertices") + " (identical positions)");
  if (R.degenerate_elements)
    P.push_back(plural(R.degenerate_elements, "degenerate tetrahedron", "degenerate tetrahedra") +
                " (zero volume or repeated vertex)");
  if (R.inverted_elements)
    P.push_back(plural(R.inverted_elements, "inverted tetrahedron", "inverted tetrahedra") + " (negative volume)");
  if (duplicate_tets) P.push_back(plural(duplicate_tets, "repeated tetrahedron", "repeated tetrahedra"));
  if (crowded_faces) P.push_back(plural(crowded_faces, "triangle", "triangles") + " shared by more than 2 tetrahedra");
  if (R.non_manifold_edges)
    P.push_back("boundary surface has " + plural(R.non_manifold_edges, "non-manifold edge", "non-manifold edges"));
  if (R.non_manifold_vertices)
    P.push_back("boundary surface has " +
                plural(R.non_manifold_vertices, "non-manifold vertex", "non-manifold vertices"));
  if (R.components > 1) P.push_back(std::to_string(R.components) + " connected components");
  return R;
}

void orient_outward(TriMesh& mesh) {
  std::vector<int> rows;
  Eigen::MatrixXi G = topological_faces(mesh.F, &rows);
  if (G.rows() == 0) return;
  EdgeTopology t = edge_topology(G);
  std::vector<char> flips;
  consistent_flips(G, t, &flips);
  for (size_t i = 0; i < rows.size(); ++i)
    if (flips[i]) std::swap(mesh.F(rows[i], 1), mesh.F(rows[i], 2));
  // Per connected component: positive enclosed volume.
  int nc = 0;
  Eigen::VectorXi comp = connected_components(mesh.F, int(mesh.V.rows()), &nc);
  std::vector<double> vol(size_t(nc), 0.0);
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    Eigen::Vector3d a = mesh.V.row(mesh.F(f, 0)), b = mesh.V.row(mesh.F(f, 1)), c = mesh.V.row(mesh.F(f, 2));
    vol[size_t(comp(mesh.F(f, 0)))] += a.dot(b.cross(c));
  }
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    if (vol[size_t(comp(mesh.F(f, 0)))] < 0) std::swap(mesh.F(f, 1), mesh.F(f, 2));
}

namespace {
// Areas and volumes of the mesh must neither overflow nor underflow a double (meshes
// scaled by 1e300 or 1e-300 otherwise pass every other check and fail deep inside).
template <class Fail>
void require_representable_size(const Eigen::MatrixXd& V, const Fail& fail) {
  const double d = bbox_diagonal(V);
  const double d3 = d * d * d;
  if (!std::isfinite(d3)) fail("coordinates too large (areas and volumes overflow); rescale the mesh");
  if (!(d3 > 0)) fail("coordinates too small or all equal (areas and volumes are zero); rescale the mesh");
}
}  // namespace

void require_genus0_surface(TriMesh& mesh, const std::string& name, int min_vertices) {
  MeshReport R = check_surface(mesh);
  auto fail = [&](const std::string& what) { throw InputError(name + ": " + what); };
  if (mesh.V.cols() != 3 || mesh.F.cols() != 3) fail(R.problems.empty() ? "bad matrix shapes" : R.problems[0]);
  if (!R.finite) fail("non-finite (NaN or Inf) vertex coordinates");
  if (!R.indices_in_range) fail("face indices out of range");
  if (R.num_elements == 0) fail("no faces");
  if (R.num_vertices < min_vertices)
    fail("only " + std::to_string(R.num_vertices) + " vertices (need at least " + std::to_string(min_vertices) + ")");
  require_representable_size(mesh.V, fail);
  if (R.degenerate_elements == R.num_elements) fail("every face is degenerate (zero area)");
  if (R.non_manifold_edges)
    fail(plural(R.non_manifold_edges, "non-manifold edge", "non-manifold edges") + " (more than 2 faces)");
  if (R.non_manifold_vertices) fail(plural(R.non_manifold_vertices, "non-manifold vertex", "non-manifold vertices"));
  if (!R.closed)
    fail("not closed: " + plural(R.boundary_edges, "boundary edge", "boundary edges") + " in " +
         plural(R.boundary_components, "hole", "holes") + "; a closed surface is needed");
  if (R.unreferenced_vertices)
    fail(plural(R.unreferenced_vertices, "unreferenced vertex", "unreferenced vertices") + " (remove them)");
  if (R.components > 1) fail(std::to_string(R.components) + " connected components; one closed surface is needed");
  if (R.genus < 0) {
    for (auto& p : R.problems)
      if (p == "not orientable") fail("not orientable");
    fail("not a closed manifold surface (faces with a repeated vertex?)");
  }
  if (R.genus != 0)
    fail("genus " + std::to_string(R.genus) + " (Euler characteristic " + std::to_string(R.euler_characteristic) +
         "); a genus-0 surface is needed");
  if (!R.consistently_oriented || enclosed_volume(mesh.V, mesh.F) < 0) orient_outward(mesh);
}

void require_valid_volume(const TetMesh& mesh, const std::string& name, double max_bad_fraction) {
  MeshReport R = check_volume(mesh);
  auto fail = [&](const std::string& what) { throw InputError(name + ": " + what); };
  if (mesh.V.cols() != 3 || mesh.T.cols() != 4) fail(R.problems.empty() ? "bad matrix shapes" : R.problems[0]);
  if (!R.finite) fail("non-finite (NaN or Inf) vertex coordinates");
  if (!R.indices_in_range) fail("tetrahedron indices out of range");
  if (R.num_elements == 0) fail("no tetrahedra");
  if (R.unreferenced_vertices)
    fail(plural(R.unreferenced_vertices, "vertex", "vertices") + " used by no tetrahedron (remove them)");
  if (R.components > 1) fail(std::to_string(R.components) + " connected components; one is needed");
  require_representable_size(mesh.V, fail);
  // Repeated tets and triangles shared by more than two tets: not a manifold volume.
  for (const std::string& p : R.problems)
    if (p.find("repeated tetrahedr") != std::string::npos || p.find("shared by more than 2") != std::string::npos)
      fail(p);
  const int bad = R.degenerate_elements + R.inverted_elements;
  if (double(bad) > max_bad_fraction * R.num_elements) {
    std::string what = std::to_string(bad) + " of " + std::to_string(R.num_elements) + " tetrahedra are degenerate (" +
                       std::to_string(R.degenerate_elements) + ") or inverted (" +
                       std::to_string(R.inverted_elements) + ")";
    if (max_bad_fraction > 0) {
      char pct[32];
      std::snprintf(pct, sizeof pct, "%g%%", 100 * max_bad_fraction);
      what += ", more than " + std::string(pct);
    }
    fail(what);
  }
}

void require_ball_topology(const TetMesh& mesh, const std::string& name) {
  MeshReport R = check_volume(mesh);
  auto fail = [&](const std::string& what) { throw InputError(name + ": " + what); };
  if (mesh.V.cols() != 3 || mesh.T.cols() != 4 || !R.indices_in_range) fail("tetrahedron indices out of range");
  if (R.num_elements == 0) fail("no tetrahedra");
  if (R.components != 1) fail(std::to_string(R.components) + " connected components; a ball is one");
  if (R.non_manifold_edges || R.non_manifold_vertices)
    fail("boundary surface is not a manifold (" + std::to_string(R.non_manifold_edges) + " non-manifold edges, " +
         std::to_string(R.non_manifold_vertices) + " non-manifold vertices); not a ball");
  if (R.boundary_components != 1)
    fail("boundary has " + std::to_string(R.boundary_components) + " components (cavities?); a ball has 1");
  if (R.genus != 0)
    fail("boundary has genus " + std::to_string(R.genus) + " (Euler characteristic " +
         std::to_string(R.euler_characteristic) + "); a ball's boundary is a sphere");
}

}  // namespace shapemap

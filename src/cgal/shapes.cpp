// Simple closed shapes (no CGAL) and the topology helpers of src/cgal/internal.h.
#include "internal.h"
#include "shapemap/checks.h"
#include "shapemap/error.h"
#include "shapemap/generate.h"
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <numeric>

namespace shapemap {
namespace cgal_internal {

namespace {

struct UnionFind {
  std::vector<int> p;
  explicit UnionFind(int n) : p(n) { std::iota(p.begin(), p.end(), 0); }
  int find(int x) {
    while (p[x] != x) x = p[x] = p[p[x]];
    return x;
  }
  void unite(int a, int b) {
    a = find(a), b = find(b);
    if (a != b) p[std::max(a, b)] = std::min(a, b);
  }
};

}  // namespace

SurfaceTopology surface_topology(const TriMesh& mesh) {
  SurfaceTopology t;
  const Eigen::MatrixXi& F = mesh.F;
  const int n = mesh.num_vertices(), m = mesh.num_faces();
  if (m == 0) return t;
  // Directed half-edges (a, b) with key (min, max); sorted to group each undirected edge.
  struct HalfEdge {
    int lo, hi;
    bool forward;  // a < b
  };
  std::vector<HalfEdge> he;
  he.reserve(size_t(m) * 3);
  for (int f = 0; f < m; ++f)
    for (int k = 0; k < 3; ++k) {
      int a = F(f, k), b = F(f, (k + 1) % 3);
      he.push_back({std::min(a, b), std::max(a, b), a < b});
    }
  std::sort(he.begin(), he.end(), [](const HalfEdge& x, const HalfEdge& y) {
    return x.lo != y.lo ? x.lo < y.lo : x.hi != y.hi ? x.hi < y.hi : x.forward < y.forward;
  });
  int num_edges = 0;
  t.closed = true, t.edge_manifold = true, t.oriented = true;
  for (size_t i = 0; i < he.size();) {
    size_t j = i;
    while (j < he.size() && he[j].lo == he[i].lo && he[j].hi == he[i].hi) ++j;
    ++num_edges;
    size_t c = j - i;
    if (c == 1) t.closed = false;
    if (c > 2) t.edge_manifold = false;
    if (c == 2 && he[i].forward == he[i + 1].forward) t.oriented = false;
    i = j;
  }
  // Vertex links: for face (v, u, w) in cyclic order, link edge u -> w. A manifold closed
  // vertex has a link that is one cycle.
  std::vector<int> start(n + 1, 0);
  for (int f = 0; f < m; ++f)
    for (int k = 0; k < 3; ++k) ++start[F(f, k) + 1];
  for (int v = 0; v < n; ++v) start[v + 1] += start[v];
  std::vector<std::pair<int, int>> link(start[n]);
  std::vector<int> fill(start.begin(), start.end() - 1);
  for (int f = 0; f < m; ++f)
    for (int k = 0; k < 3; ++k)
      link[fill[F(f, k)]++] = {F(f, (k + 1) % 3), F(f, (k + 2) % 3)};
  t.vertex_manifold = true;
  for (int v = 0; v < n && t.vertex_manifold; ++v) {
    auto b = link.begin() + start[v], e = link.begin() + start[v + 1];
    if (b == e) continue;
    std::sort(b, e);
    for (auto it = b; it + 1 < e; ++it)
      if (it->first == (it + 1)->first) t.vertex_manifold = false;
    if (!t.vertex_manifold || !t.closed || !t.oriented) continue;  // cycle test needs a closed oriented link
    int steps = 0, u = b->first;
    do {
      auto it = std::lower_bound(b, e, std::make_pair(u, -1));
      if (it == e || it->first != u) break;
      u = it->second;
      ++steps;
    } while (u != b->first && steps <= int(e - b));
    if (u != b->first || steps != int(e - b)) t.vertex_manifold = false;
  }
  UnionFind uf(n);
  for (int f = 0; f < m; ++f) uf.unite(F(f, 0), F(f, 1)), uf.unite(F(f, 0), F(f, 2));
  std::vector<char> seen(n, 0);
  int comps = 0;
  for (int f = 0; f < m; ++f) {
    int r = uf.find(F(f, 0));
    if (!seen[r]) seen[r] = 1, ++comps;
  }
  t.components = comps;
  int nv = 0;
  for (int v = 0; v < n; ++v) nv += start[v + 1] > start[v];
  t.euler = nv - num_edges + m;
  return t;
}

void require_closed_manifold(const TriMesh& mesh, const std::string& name) {
  const int n = mesh.num_vertices(), m = mesh.num_faces();
  if (m < 4 || n < 4) throw InputError(name + ": too few faces for a closed surface");
  if (mesh.F.cols() != 3) throw InputError(name + ": faces are not triangles");
  if (!mesh.V.allFinite()) throw InputError(name + ": non-finite vertex coordinates");
  for (int f = 0; f < m; ++f) {
    for (int k = 0; k < 3; ++k)
      if (mesh.F(f, k) < 0 || mesh.F(f, k) >= n)
        throw InputError(name + ": face " + std::to_string(f) + " has a vertex index out of range");
    if (mesh.F(f, 0) == mesh.F(f, 1) || mesh.F(f, 1) == mesh.F(f, 2) || mesh.F(f, 0) == mesh.F(f, 2))
      throw InputError(name + ": face " + std::to_string(f) + " repeats a vertex");
  }
  // CGAL's polyhedral domain asserts on unused vertices and fails on zero-area faces
  // (e.g. two vertices at the same position): clear input errors instead.
  const MeshReport r = check_surface(mesh);
  if (r.unreferenced_vertices > 0)
    throw InputError(name + ": " + std::to_string(r.unreferenced_vertices) +
                     " vertices are used by no face (remove them)");
  if (r.degenerate_elements > 0)
    throw InputError(name + ": " + std::to_string(r.degenerate_elements) +
                     " degenerate (zero-area) faces; duplicate vertices?");
  SurfaceTopology t = surface_topology(mesh);
  if (!t.edge_manifold) throw InputError(name + ": non-manifold edges (an edge has more than two faces)");
  if (!t.closed) throw InputError(name + ": surface is not closed (it has boundary edges)");
  if (!t.vertex_manifold) throw InputError(name + ": non-manifold vertices");
  if (!t.oriented) throw InputError(name + ": faces are not consistently oriented");
}

void compact_vertices(TriMesh& mesh) {
  std::vector<int> map(mesh.num_vertices(), -1);
  int k = 0;
  for (int f = 0; f < mesh.num_faces(); ++f)
    for (int j = 0; j < 3; ++j) {
      int& v = mesh.F(f, j);
      if (map[v] < 0) map[v] = k++;
      v = map[v];
    }
  Eigen::MatrixXd V(k, 3);
  for (int i = 0; i < int(map.size()); ++i)
    if (map[i] >= 0) V.row(map[i]) = mesh.V.row(i);
  mesh.V = std::move(V);
}

}  // namespace cgal_internal

namespace {

void orient_positive(TriMesh& m) {
  if (enclosed_volume(m.V, m.F) < 0) m.F.col(1).swap(m.F.col(2));
}

// The mesh of a point list and a triangle list, its faces turned outward.
TriMesh oriented_mesh(const std::vector<Eigen::Vector3d>& pts, const std::vector<std::array<int, 3>>& faces) {
  TriMesh m;
  m.V.resize(pts.size(), 3);
  for (size_t i = 0; i < pts.size(); ++i) m.V.row(i) = pts[i].transpose();
  m.F.resize(faces.size(), 3);
  for (size_t i = 0; i < faces.size(); ++i) m.F.row(i) << faces[i][0], faces[i][1], faces[i][2];
  orient_positive(m);
  return m;
}

// Geodesic icosahedron of frequency nf: each icosahedron face split into nf^2 triangles,
// 10 nf^2 + 2 vertices, projected to the unit sphere.
TriMesh geodesic_sphere(int nf) {
  const double t = (1 + std::sqrt(5.0)) / 2;
  const double ico_v[12][3] = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0},
                               {0, -1, t}, {0, 1, t}, {0, -1, -t}, {0, 1, -t},
                               {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  const int ico_f[20][3] = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                            {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                            {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                            {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  // A point of a face with integer weights (i, j, k), i + j + k = nf, on corners (a, b, c);
  // key: the (corner id, weight) pairs with non-zero weight, sorted, so points shared
  // by faces get one id.
  std::map<std::array<int, 6>, int> ids;
  std::vector<Eigen::Vector3d> pts;
  auto vertex = [&](int a, int b, int c, int i, int j, int k) {
    std::array<std::pair<int, int>, 3> w = {{{a, i}, {b, j}, {c, k}}};
    std::sort(w.begin(), w.end());
    std::array<int, 6> key{};
    int q = 0;
    for (auto& [id, wt] : w)
      if (wt > 0) key[q++] = id + 1, key[q++] = wt;
    auto [it, inserted] = ids.emplace(key, int(pts.size()));
    if (inserted) {
      Eigen::Vector3d p = (i * Eigen::Vector3d(ico_v[a][0], ico_v[a][1], ico_v[a][2]) +
                           j * Eigen::Vector3d(ico_v[b][0], ico_v[b][1], ico_v[b][2]) +
                           k * Eigen::Vector3d(ico_v[c][0], ico_v[c][1], ico_v[c][2])) /
                          double(nf);
      pts.push_back(p.normalized());
    }
    return it->second;
  };
  std::vector<std::array<int, 3>> faces;
  for (auto& f : ico_f) {
    const int a = f[0], b = f[1], c = f[2];
    // Rows along a -> b (j), columns towards c (k).
    for (int k = 0; k < nf; ++k)
      for (int j = 0; j + k < nf; ++j) {
        int i = nf - j - k;
        int p0 = vertex(a, b, c, i, j, k), p1 = vertex(a, b, c, i - 1, j + 1, k),
            p2 = vertex(a, b, c, i - 1, j, k + 1);
        faces.push_back({p0, p1, p2});
        if (j + k + 1 < nf) {
          int p3 = vertex(a, b, c, i - 2, j + 1, k + 1);
          faces.push_back({p1, p3, p2});
        }
      }
  }
  return oriented_mesh(pts, faces);
}

}  // namespace

TriMesh make_sphere(int target_vertices, double radius) {
  if (target_vertices < 12) throw InputError("sphere: needs at least 12 vertices");
  if (!(radius > 0)) throw InputError("sphere: radius must be positive");
  int nf = std::max(1, int(std::lround(std::sqrt((target_vertices - 2) / 10.0))));
  TriMesh m = geodesic_sphere(nf);
  m.V *= radius;
  return m;
}

TriMesh make_ellipsoid(int target_vertices, const Eigen::Vector3d& radii) {
  if (!(radii.minCoeff() > 0)) throw InputError("ellipsoid: radii must be positive");
  TriMesh m = make_sphere(target_vertices, 1.0);
  for (int i = 0; i < m.num_vertices(); ++i)
    m.V.row(i) = m.V.row(i).cwiseProduct(radii.transpose());
  return m;
}

TriMesh make_torus(int target_vertices, double R, double r) {
  if (!(r > 0) || !(R > r)) throw InputError("torus: needs 0 < r < R");
  if (target_vertices < 9) throw InputError("torus: needs at least 9 vertices");
  // nu * nv = target, nu / nv = R / r (square-ish quads on the mid circle).
  int nv = std::max(3, int(std::lround(std::sqrt(target_vertices * r / R))));
  int nu = std::max(3, int(std::lround(double(target_vertices) / nv)));
  TriMesh m;
  m.V.resize(nu * nv, 3);
  m.F.resize(2 * nu * nv, 3);
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      double u = 2 * M_PI * i / nu, v = 2 * M_PI * j / nv;
      m.V.row(i * nv + j) << (R + r * std::cos(v)) * std::cos(u), (R + r * std::cos(v)) * std::sin(u),
          r * std::sin(v);
      int a = i * nv + j, b = ((i + 1) % nu) * nv + j, c = ((i + 1) % nu) * nv + (j + 1) % nv,
          d = i * nv + (j + 1) % nv;
      m.F.row(2 * a) << a, b, c;
      m.F.row(2 * a + 1) << a, c, d;
    }
  orient_positive(m);
  return m;
}

TriMesh make_cube_sphere(int target_vertices) {
  if (target_vertices < 8) throw InputError("cube-sphere: needs at least 8 vertices");
  // n cells per cube edge: 6 n^2 + 2 vertices. Equal-angle (tan) spacing on each face.
  const int n = std::max(1, int(std::lround(std::sqrt((target_vertices - 2) / 6.0))));
  std::map<std::array<int, 3>, int> ids;
  std::vector<Eigen::Vector3d> pts;
  auto vertex = [&](const std::array<int, 3>& g) {
    auto [it, inserted] = ids.emplace(g, int(pts.size()));
    if (inserted) {
      Eigen::Vector3d p;
      for (int d = 0; d < 3; ++d) p(d) = std::tan(M_PI / 4 * (2.0 * g[d] / n - 1));
      pts.push_back(p.normalized());
    }
    return it->second;
  };
  std::vector<std::array<int, 3>> faces;
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      int u = (axis + 1) % 3, w = (axis + 2) % 3;
      for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
          auto g = [&](int a, int b) {
            std::array<int, 3> q;
            q[axis] = side * n, q[u] = a, q[w] = b;
            return vertex(q);
          };
          int p00 = g(i, j), p10 = g(i + 1, j), p11 = g(i + 1, j + 1), p01 = g(i, j + 1);
          // (u, w, axis) is right-handed: counter-clockwise seen from +axis.
          if (side == 1) {
            faces.push_back({p00, p10, p11});
            faces.push_back({p00, p11, p01});
          } else {
            faces.push_back({p00, p11, p10});
            faces.push_back({p00, p01, p11});
          }
        }
    }
  return oriented_mesh(pts, faces);
}

}  // namespace shapemap

// Safe repairs of input surfaces with CGAL's Polygon Mesh Processing (the only CGAL
// translation unit of the repairs; the correspondence helpers are in
// src/geometry/surface_repair_maps.cpp). docs/methods.md, "Input repairs".
#include "shapemap/repair.h"
#include "shapemap/checks.h"
#include "shapemap/error.h"
#include "shapemap/geometry/closest_point.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/border.h>
#include <CGAL/Polygon_mesh_processing/connected_components.h>
#include <CGAL/Polygon_mesh_processing/measure.h>
#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/repair_degeneracies.h>
#include <CGAL/Polygon_mesh_processing/shape_predicates.h>
#include <CGAL/Polygon_mesh_processing/stitch_borders.h>
#include <CGAL/Polygon_mesh_processing/triangulate_hole.h>
#include <CGAL/Surface_mesh.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numeric>

namespace shapemap {

namespace {

namespace PMP = CGAL::Polygon_mesh_processing;
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using Mesh = CGAL::Surface_mesh<Point>;
using VI = Mesh::Vertex_index;
using FI = Mesh::Face_index;

// Records which soup point each point that orient_polygon_soup appends is a copy of.
struct CopyVisitor : public PMP::Default_orientation_visitor {
  std::vector<int>* from = nullptr;
  void duplicated_vertex(std::size_t original, std::size_t copy) {
    if (from->size() <= copy) from->resize(copy + 1, -1);
    (*from)[copy] = (*from)[original];
  }
};

std::string count(long long n, const char* one, const char* many) {
  return std::to_string(n) + " " + (n == 1 ? one : many);
}

// Representative of each vertex among those at exactly its position: the smallest index.
std::vector<int> exact_duplicates(const Eigen::MatrixXd& V) {
  std::vector<int> idx(size_t(V.rows()));
  std::iota(idx.begin(), idx.end(), 0);
  auto less = [&](int a, int b) {
    for (int j = 0; j < 3; ++j)
      if (V(a, j) != V(b, j)) return V(a, j) < V(b, j);
    return a < b;
  };
  std::sort(idx.begin(), idx.end(), less);
  std::vector<int> rep(idx.size());
  for (size_t k = 0; k < idx.size(); ++k) {
    const bool same = k > 0 && V.row(idx[k]) == V.row(idx[k - 1]);
    rep[size_t(idx[k])] = same ? rep[size_t(idx[k - 1])] : idx[k];
  }
  return rep;
}

// 2. The faces of in with vertices replaced by their representatives rep, without those with
// a repeated vertex or repeating an earlier face; face_from: each kept face's input index.
void nondegenerate_faces(const TriMesh& in, const std::vector<int>& rep, std::vector<std::array<int, 3>>& faces,
                         std::vector<int>& face_from, int& repeated_vertex, int& repeated_face) {
  const int m = int(in.F.rows());
  std::vector<std::pair<std::array<int, 3>, int>> keys;
  for (int f = 0; f < m; ++f) {
    const std::array<int, 3> t = {rep[size_t(in.F(f, 0))], rep[size_t(in.F(f, 1))], rep[size_t(in.F(f, 2))]};
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) {
      ++repeated_vertex;
      continue;
    }
    std::array<int, 3> k = t;
    std::sort(k.begin(), k.end());
    keys.push_back({k, f});
  }
  std::sort(keys.begin(), keys.end());
  std::vector<char> keep(size_t(m), 0);
  for (size_t k = 0; k < keys.size(); ++k) {
    if (k > 0 && keys[k].first == keys[k - 1].first) {
      ++repeated_face;
      continue;
    }
    keep[size_t(keys[k].second)] = 1;
  }
  for (int f = 0; f < m; ++f)
    if (keep[size_t(f)]) {
      faces.push_back({rep[size_t(in.F(f, 0))], rep[size_t(in.F(f, 1))], rep[size_t(in.F(f, 2))]});
      face_from.push_back(f);
    }
}

// 4. Zero-area faces removed (CGAL's exact test; edges collapsed or flipped). On a copy: if
// CGAL gives up, the surface is kept as it was (returns 0) and the guards note the faces.
int remove_zero_area_faces(Mesh& mesh) {
  int zero_area = 0;
  for (FI f : mesh.faces()) zero_area += PMP::is_degenerate_triangle_face(f, mesh);
  if (zero_area == 0) return 0;
  Mesh trial = mesh;
  bool ok = false;
  try {
    ok = PMP::remove_degenerate_faces(trial);
  } catch (const std::exception&) {
    ok = false;
  }
  if (!ok) return 0;
  trial.collect_garbage();
  mesh = std::move(trial);
  return zero_area;
}

// 5. Components other than the largest (by area) set aside, when together they are small.
void set_aside_small_components(Mesh& mesh, const SurfaceRepairOptions& opt, const std::string& note,
                                std::vector<std::string>& notes) {
  auto fcc = mesh.add_property_map<FI, std::size_t>("f:shapemap_cc", 0).first;
  const std::size_t nc = PMP::connected_components(mesh, fcc);
  if (nc > 1) {
    std::vector<double> area(nc, 0.0);
    std::vector<int> nf(nc, 0);
    for (FI f : mesh.faces()) {
      area[fcc[f]] += PMP::face_area(f, mesh);
      ++nf[fcc[f]];
    }
    const std::size_t best = size_t(std::max_element(area.begin(), area.end()) - area.begin());
    const double total = std::accumulate(area.begin(), area.end(), 0.0);
    const double rest = total - area[best];
    if (total > 0 && rest <= opt.max_set_aside_area * total) {
      int set_aside_vertices = 0;
      for (VI v : mesh.vertices()) {
        bool kept = false;
        if (mesh.is_isolated(v)) continue;
        for (FI f : CGAL::faces_around_target(mesh.halfedge(v), mesh))
          if (f != Mesh::null_face() && fcc[f] == best) kept = true;
        set_aside_vertices += !kept;
      }
      const int faces_aside = int(mesh.number_of_faces()) - nf[best];
      PMP::keep_connected_components(mesh, std::vector<std::size_t>{best}, fcc);
      mesh.collect_garbage();
      char pct[32];
      std::snprintf(pct, sizeof pct, "%.2g%%", 100 * rest / total);
      notes.push_back(note + count(long(nc - 1), "smaller component", "smaller components") + " set aside (" +
                      count(faces_aside, "face", "faces") + ", " + pct + " of the area); their " +
                      count(set_aside_vertices, "vertex maps", "vertices map") +
                      " through the nearest point of the kept surface");
    }
  }
  mesh.remove_property_map(fcc);
}

// 6. Small holes filled (triangulated and refined to the surrounding edge lengths).
void fill_small_holes(Mesh& mesh, const SurfaceRepairOptions& opt, const std::string& note,
                      std::vector<std::string>& notes) {
  std::vector<Mesh::Halfedge_index> cycles;
  PMP::extract_boundary_cycles(mesh, std::back_inserter(cycles));
  const double area = PMP::area(mesh);
  int filled = 0, edges = 0, added_faces = 0, added_vertices = 0;
  for (Mesh::Halfedge_index h : cycles) {
    double length = 0;
    int k = 0;
    for (Mesh::Halfedge_index e : CGAL::halfedges_around_face(h, mesh)) {
      length += std::sqrt(CGAL::squared_distance(mesh.point(mesh.source(e)), mesh.point(mesh.target(e))));
      ++k;
    }
    if (!(length * length / (4 * M_PI) <= opt.max_hole_area * area)) continue;
    std::vector<FI> new_faces;
    std::vector<VI> new_vertices;
    try {
      PMP::triangulate_and_refine_hole(mesh, h, std::back_inserter(new_faces), std::back_inserter(new_vertices));
    } catch (const std::exception&) {
      continue;  // left open: the guard reports the hole
    }
    if (new_faces.empty()) continue;
    ++filled;
    edges += k;
    added_faces += int(new_faces.size());
    added_vertices += int(new_vertices.size());
  }
  if (filled)
    notes.push_back(note + count(filled, "small hole", "small holes") + " filled (" +
                    count(edges, "boundary edge", "boundary edges") + "; " + count(added_faces, "face", "faces") +
                    " and " + count(added_vertices, "vertex", "vertices") + " added)");
}

// The repaired surface and its correspondence to the input in: each input vertex to its
// first copy, its duplicate's (rep), or the nearest point of the repaired surface.
SurfaceRepair repair_result(const Mesh& mesh, const Mesh::Property_map<VI, int>& vfrom,
                            const Mesh::Property_map<FI, int>& ffrom, const TriMesh& in,
                            const std::vector<int>& rep, std::vector<std::string> notes) {
  const int n = int(in.V.rows());
  SurfaceRepair R;
  R.notes = std::move(notes);
  const int nv = int(mesh.number_of_vertices()), nf = int(mesh.number_of_faces());
  R.mesh.V.resize(nv, 3);
  R.vertex_from.resize(nv);
  for (VI v : mesh.vertices()) {
    const Point& p = mesh.point(v);
    R.mesh.V.row(int(v)) << p.x(), p.y(), p.z();
    R.vertex_from(int(v)) = vfrom[v];
  }
  R.mesh.F.resize(nf, 3);
  R.face_from.resize(nf);
  for (FI f : mesh.faces()) {
    int j = 0;
    for (VI v : CGAL::vertices_around_face(mesh.halfedge(f), mesh)) R.mesh.F(int(f), j++) = int(v);
    // A face that CGAL rebuilt (an edge flip) no longer has its input face's corners.
    int g = ffrom[f];
    for (int c = 0; c < 3 && g >= 0; ++c) {
      bool found = false;
      for (int k = 0; k < 3; ++k) found |= R.mesh.V.row(R.mesh.F(int(f), c)) == in.V.row(in.F(g, k));
      if (!found) g = -1;
    }
    R.face_from(int(f)) = g;
  }
  orient_outward(R.mesh);

  // Each input vertex: its first copy, its duplicate's, or the nearest point.
  R.input_vertex = Eigen::VectorXi::Constant(n, -1);
  for (int v = 0; v < nv; ++v)
    if (R.vertex_from(v) >= 0 && R.input_vertex(R.vertex_from(v)) < 0) R.input_vertex(R.vertex_from(v)) = v;
  for (int i = 0; i < n; ++i) R.input_vertex(i) = R.input_vertex(rep[size_t(i)]);
  std::vector<int> a_face(size_t(nv), -1), a_corner(size_t(nv), 0);
  for (int f = nf - 1; f >= 0; --f)
    for (int c = 0; c < 3; ++c) a_face[size_t(R.mesh.F(f, c))] = f, a_corner[size_t(R.mesh.F(f, c))] = c;
  R.input_on_repaired.elem.resize(n);
  R.input_on_repaired.bary = Eigen::MatrixXd::Zero(n, 3);
  std::vector<int> lost;
  for (int i = 0; i < n; ++i) {
    const int v = R.input_vertex(i);
    if (v >= 0 && a_face[size_t(v)] >= 0) {
      R.input_on_repaired.elem(i) = a_face[size_t(v)];
      R.input_on_repaired.bary(i, a_corner[size_t(v)]) = 1.0;
    } else {
      R.input_vertex(i) = -1;
      lost.push_back(i);
    }
  }
  if (!lost.empty()) {
    ClosestPoint3 bvh(R.mesh.V, R.mesh.F);
    for (int i : lost) {
      const ClosestPointResult c = bvh.query(Eigen::Vector3d(in.V.row(i).transpose()));
      R.input_on_repaired.elem(i) = c.elem;
      Eigen::RowVector3d b = c.bary.head<3>().transpose().cwiseMax(0.0);
      R.input_on_repaired.bary.row(i) = b.sum() > 0 ? Eigen::RowVector3d(b / b.sum()) : Eigen::RowVector3d(1, 0, 0);
    }
  }
  return R;
}

// The polygon soup of the kept faces: the input vertices they reference (representatives
// after merging), numbered in input order as points (point_of: input vertex -> point or -1;
// soup_from: point -> input vertex), and the faces in that numbering.
void polygon_soup(const TriMesh& in, const std::vector<std::array<int, 3>>& faces, std::vector<int>& point_of,
                  std::vector<Point>& points, std::vector<int>& soup_from,
                  std::vector<std::vector<std::size_t>>& polygons) {
  const int n = int(in.V.rows());
  point_of.assign(size_t(n), -1);
  for (const auto& t : faces)
    for (int v : t) point_of[size_t(v)] = -2;  // mark; numbered below in input order
  for (int i = 0; i < n; ++i)
    if (point_of[size_t(i)] == -2) {
      point_of[size_t(i)] = int(points.size());
      points.emplace_back(in.V(i, 0), in.V(i, 1), in.V(i, 2));
      soup_from.push_back(i);
    }
  polygons.reserve(faces.size());
  for (const auto& t : faces)
    polygons.push_back({size_t(point_of[size_t(t[0])]), size_t(point_of[size_t(t[1])]), size_t(point_of[size_t(t[2])])});
}

// Step 3's orientation of the soup (CGAL orient_polygon_soup), which splits the non-manifold
// edges and vertices: the copies it appends get their original's input vertex in soup_from.
// nm_edges, nm_vertices: the non-manifold edges and vertices of the soup before, as
// `shapemap check` counts them.
void orient_soup(std::vector<Point>& points, std::vector<std::vector<std::size_t>>& polygons,
                 std::vector<int>& soup_from, int& nm_edges, int& nm_vertices) {
  TriMesh soup;
  soup.V.resize(Eigen::Index(points.size()), 3);
  for (size_t p = 0; p < points.size(); ++p)
    soup.V.row(Eigen::Index(p)) << points[p].x(), points[p].y(), points[p].z();
  soup.F.resize(Eigen::Index(polygons.size()), 3);
  for (size_t f = 0; f < polygons.size(); ++f)
    for (int j = 0; j < 3; ++j) soup.F(Eigen::Index(f), j) = int(polygons[f][size_t(j)]);
  const MeshReport r = check_surface(soup);
  nm_edges = r.non_manifold_edges;
  nm_vertices = r.non_manifold_vertices;
  CopyVisitor visitor;
  visitor.from = &soup_from;
  PMP::orient_polygon_soup(points, polygons, CGAL::parameters::visitor(visitor));
}

}  // namespace

SurfaceRepair repair_surface(const TriMesh& in, const std::string& name, const SurfaceRepairOptions& opt) {
  const std::vector<std::string> defects = repairable_defects(in);
  if (defects.empty()) return identity_repair(in);
  if (opt.strict) {
    std::string all;
    for (const std::string& d : defects) all += (all.empty() ? "" : ", ") + d;
    throw InputError(name + ": " + all + " (--strict: not repaired)");
  }
  const std::string note = name + ": note: ";
  std::vector<std::string> notes;
  const int n = int(in.V.rows());

  // 1. Duplicate vertices merged (identical positions, as `shapemap check` counts them).
  const std::vector<int> rep = exact_duplicates(in.V);
  int merged = 0;
  for (int i = 0; i < n; ++i) merged += rep[size_t(i)] != i;
  if (merged) notes.push_back(note + count(merged, "duplicate vertex", "duplicate vertices") + " merged (identical positions)");

  // 2. Faces with a repeated vertex (after merging) and repeated faces removed.
  std::vector<std::array<int, 3>> faces;
  std::vector<int> face_from;
  int repeated_vertex = 0, repeated_face = 0;
  nondegenerate_faces(in, rep, faces, face_from, repeated_vertex, repeated_face);

  if (repeated_vertex + repeated_face > 0) {
    std::string what = repeated_vertex ? std::to_string(repeated_vertex) + " with a repeated vertex" : "";
    if (repeated_face) what += (what.empty() ? "" : ", ") + std::to_string(repeated_face) + " repeating another face";
    notes.push_back(note + count(repeated_vertex + repeated_face, "degenerate face", "degenerate faces") +
                    " removed (" + what + ")");
  }

  if (faces.empty()) return identity_repair(in);  // every face degenerate: the guard says so
  std::vector<int> point_of, soup_from;
  std::vector<Point> points;
  std::vector<std::vector<std::size_t>> polygons;
  polygon_soup(in, faces, point_of, points, soup_from, polygons);
  int unreferenced = 0;
  for (int i = 0; i < n; ++i) unreferenced += point_of[size_t(rep[size_t(i)])] < 0;

  // 3. Non-manifold edges and vertices split: orient_polygon_soup duplicates the points
  // whose neighbourhood is not a disk (appended, so the first copy keeps the point's index)
  // and cuts the faces around a non-manifold edge apart; the slit this leaves in each sheet
  // (a boundary cycle running along the edge and back) is zipped by stitching within each
  // boundary cycle only, so the sheets stay apart.
  int nm_edges = 0, nm_vertices = 0;
  const size_t soup_points = points.size();
  orient_soup(points, polygons, soup_from, nm_edges, nm_vertices);
  if (!PMP::is_polygon_soup_a_polygon_mesh(polygons))
    throw InputError(name + ": could not be made a manifold surface (CGAL orient_polygon_soup)");
  Mesh mesh;
  PMP::polygon_soup_to_polygon_mesh(points, polygons, mesh);
  auto vfrom = mesh.add_property_map<VI, int>("v:shapemap_from", -1).first;
  auto ffrom = mesh.add_property_map<FI, int>("f:shapemap_from", -1).first;
  for (size_t p = 0; p < points.size(); ++p) vfrom[VI(Mesh::size_type(p))] = soup_from[p];
  for (size_t f = 0; f < polygons.size(); ++f) ffrom[FI(Mesh::size_type(f))] = face_from[f];
  if (points.size() > soup_points) {
    PMP::stitch_boundary_cycles(mesh);
    mesh.collect_garbage();
    vfrom = mesh.property_map<VI, int>("v:shapemap_from").first;
    ffrom = mesh.property_map<FI, int>("f:shapemap_from").first;
  }
  const long copies = long(mesh.number_of_vertices()) - long(soup_points);
  if (nm_edges || nm_vertices || copies > 0)
    notes.push_back(note + count(nm_edges, "non-manifold edge", "non-manifold edges") + " and " +
                    count(nm_vertices, "non-manifold vertex", "non-manifold vertices") + " split (" +
                    count(std::max(copies, 0L), "vertex", "vertices") + " duplicated; copies map like their original)");

  const int zero_area = remove_zero_area_faces(mesh);
  if (zero_area > 0) {
    vfrom = mesh.property_map<VI, int>("v:shapemap_from").first;
    ffrom = mesh.property_map<FI, int>("f:shapemap_from").first;
  }
  if (zero_area > 0)
    notes.push_back(note + count(zero_area, "degenerate face", "degenerate faces") +
                    " removed (zero area; CGAL's edge collapses and flips)");
  if (unreferenced)
    notes.push_back(note + count(unreferenced, "vertex", "vertices") +
                    " used by no face set aside (mapped through the nearest point of the surface)");

  set_aside_small_components(mesh, opt, note, notes);

  fill_small_holes(mesh, opt, note, notes);
  if (notes.empty()) return identity_repair(in);  // nothing changed after all
  for (VI v : mesh.vertices())
    if (mesh.is_isolated(v)) mesh.remove_vertex(v);  // left by CGAL's collapses: mapped by nearest point
  mesh.collect_garbage();

  return repair_result(mesh, vfrom, ffrom, in, rep, std::move(notes));
}

}  // namespace shapemap

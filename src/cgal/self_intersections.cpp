// tetrahedralize(): the self-intersection check before meshing and, when Mesh_3 runs away
// on a crossing surface, the crossings removed (CGAL Polygon Mesh Processing). Apart from
// tetrahedralize.cpp (the Mesh_3 instantiation) so that the two compile side by side.
#include "shapemap/volume/tetrahedralize.h"
#include "internal.h"
#include "surface_mesh.h"
#include "shapemap/error.h"

#include <CGAL/Polygon_mesh_processing/repair_self_intersections.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>

#include <string>
#include <unordered_map>

namespace shapemap {

// One meshing of `surface` (crossings: its count of crossing face pairs, for info);
// tetrahedralize.cpp.
TetMesh tetrahedralize_once(const TriMesh& surface, const TetrahedralizeOptions& opt,
                            const ProgressCallback& progress, TetrahedralizeInfo* info,
                            int crossings);

namespace {

using cgal_internal::SurfaceMesh;
using cgal_internal::to_surface_mesh;

// An output iterator that only counts what is written to it (the self-intersecting pairs).
struct PairCounter {
  int* n;
  PairCounter& operator*() { return *this; }
  PairCounter& operator++() { return *this; }
  PairCounter operator++(int) { return *this; }
  template <class T>
  PairCounter& operator=(const T&) {
    ++*n;
    return *this;
  }
};

}  // namespace

int self_intersecting_face_pairs(const TriMesh& surface) {
  cgal_internal::require_closed_manifold(surface, "surface");
  int n = 0;
  CGAL::Polygon_mesh_processing::self_intersections(to_surface_mesh(surface, "surface"), PairCounter{&n});
  return n;
}

namespace {
// The surface with its self-intersections removed by CGAL (Polygon Mesh Processing,
// experimental::remove_self_intersections: crossing faces and a small neighbourhood are
// removed and the holes filled, smoothly). False when CGAL cannot, or the result is no
// longer a closed manifold surface without crossings.
bool without_self_intersections(const TriMesh& surface, TriMesh& out) {
  SurfaceMesh sm = to_surface_mesh(surface, "surface");
  namespace P = CGAL::parameters;
  bool ok = false;
  try {
    ok = CGAL::Polygon_mesh_processing::experimental::remove_self_intersections(
        sm, P::preserve_genus(true));
  } catch (const CGAL::Failure_exception&) {
    return false;
  }
  if (!ok) return false;
  sm.collect_garbage();
  std::unordered_map<SurfaceMesh::Vertex_index, int> id;
  out.V.resize(sm.number_of_vertices(), 3);
  int k = 0;
  for (auto v : sm.vertices()) {
    const auto& p = sm.point(v);
    out.V.row(k) << p.x(), p.y(), p.z();
    id[v] = k++;
  }
  out.F.resize(sm.number_of_faces(), 3);
  k = 0;
  for (auto f : sm.faces()) {
    int c = 0;
    for (auto v : CGAL::vertices_around_face(sm.halfedge(f), sm)) {
      if (c == 3) return false;
      out.F(k, c++) = id[v];
    }
    if (c != 3) return false;
    ++k;
  }
  const cgal_internal::SurfaceTopology t = cgal_internal::surface_topology(out);
  if (!(t.closed && t.edge_manifold && t.vertex_manifold && t.oriented && t.components == 1)) return false;
  return !CGAL::Polygon_mesh_processing::does_self_intersect(sm);
}
}  // namespace

TetMesh tetrahedralize(const TriMesh& surface, const TetrahedralizeOptions& opt,
                       const ProgressCallback& progress, TetrahedralizeInfo* info) {
  const int crossings = self_intersecting_face_pairs(surface);
  if (crossings == 0) return tetrahedralize_once(surface, opt, progress, info, 0);
  try {
    return tetrahedralize_once(surface, opt, progress, info, crossings);
  } catch (const InputError& e) {
    // Mesh_3 ran away on a crossing surface (tosca-cat-00.off: 86 crossing pairs, over 60k
    // vertices): the crossings removed by CGAL, then meshed again (reported in info).
    TriMesh fixed;
    if (!without_self_intersections(surface, fixed))
      throw InputError(std::string(e.what()) + "; it crosses itself (" + std::to_string(crossings) +
                       " pairs of faces), which CGAL could not repair");
    TetMesh out = tetrahedralize_once(fixed, opt, progress, info, 0);
    if (info) {
      info->self_intersecting_pairs = crossings;
      info->self_intersections_removed = true;
    }
    return out;
  }
}

}  // namespace shapemap

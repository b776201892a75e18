// Tetrahedralization of a closed surface with CGAL Mesh_3.
#pragma once
#include "shapemap/mesh.h"
#include "shapemap/progress.h"
#include <functional>
#include <string>
#include <vector>

namespace shapemap {

// Largest tet count tetrahedralize() accepts (explicit or implied by edge_length).
constexpr int kMaxTetrahedralizeTets = 5000000;

struct TetrahedralizeOptions {
  double edge_length = 0;      // target tet edge length (0: derived from target_tets or the input)
  int target_tets = 0;         // approximate tet count (0: use edge_length or ~30k)
  double radius_edge_ratio = 3.0;  // Mesh_3 cell criterion (issue: <= 3)
  bool faithful_boundary = true;   // protect and keep the input surface (polyhedral domain)
  bool optimize = true;            // ODT (when odt), perturbation, exudation
  unsigned seed = 0;
  bool odt = true;                 // CGAL ODT smoothing before perturb/exude (~2 s per 30k
                                   // tets; lowers ball-map distortion, docs/methods.md)
  double sliver_bound = 10;        // perturb/exude target: smallest dihedral angle (degrees)
  double optimize_time_limit = 0;  // seconds per sliver step; 0 = none (keeps runs deterministic)
  double crease_time_limit = 60;   // seconds for the crease-protected meshing before it is
                                   // dropped for plain meshing (0 = none; noisy inputs only)
};

// What tetrahedralize() did with the sharp creases of the input (for the caller's report).
struct TetrahedralizeInfo {
  bool creases_protected = false;  // creases found and kept as protected 1D features
  std::string creases_dropped;     // non-empty: CGAL's crease protection failed (its check,
                                   // quoted); the surface was meshed without it
  bool odt_smoothed = false;       // the result is ODT-smoothed
  std::string odt_dropped;         // non-empty: the ODT-smoothed mesh failed check_volume
                                   // (its first problem); the result is meshed without ODT
  int self_intersecting_pairs = 0; // > 0: the surface crosses itself (pairs of faces); the
                                   // inside by ray parity was meshed without crease protection
  bool self_intersections_removed = false;  // that meshing ran away, and the crossings were
                                            // removed (CGAL PMP) before meshing again
  int touching_vertices = 0;       // > 0: vertices at the position of another (the surface
                                   // touches itself, e.g. where repair_surface() split a
                                   // non-manifold edge): meshed without Mesh_3's manifold
                                   // criterion, so the boundary may have non-manifold edges there
  std::string manifold_dropped;    // non-empty: meshing with the manifold criterion failed (why);
                                   // the surface was meshed again without it
};

// One line per thing tetrahedralize() did that its caller should tell the user,
// "<name>: note: ...", in a fixed order (the CLI and the volume-map pipeline print them).
std::vector<std::string> tetrahedralize_notes(const TetrahedralizeInfo& info, const std::string& name);

// Pairs of faces of a closed manifold surface that intersect other than along the edges and
// vertices they share (CGAL Polygon_mesh_processing::self_intersections, exact predicates).
// Throws InputError if the surface is not a closed, oriented manifold.
int self_intersecting_face_pairs(const TriMesh& surface);

// V, F: closed, manifold, consistently oriented surface. Throws InputError if not.
// The result has positively oriented tets and no inverted elements.
TetMesh tetrahedralize(const TriMesh& surface, const TetrahedralizeOptions& opt = {},
                       const ProgressCallback& progress = {}, TetrahedralizeInfo* info = nullptr);

// The ODT fallback of tetrahedralize(), exposed for tests. ODT moves vertices after Mesh_3's
// manifold criterion has been enforced, so it can leave defects: non-manifold boundary edges
// or vertices, degenerate or inverted tets. `smoothed` is kept unless it has such defects and
// `remesh_plain` (the same meshing without ODT; it fills its own info) returns a mesh with
// fewer. `info` gets odt_smoothed, or the plain run's info with odt_dropped naming the
// smoothed mesh's first problem.
TetMesh keep_odt_unless_defective(TetMesh smoothed,
                                  const std::function<TetMesh(TetrahedralizeInfo*)>& remesh_plain,
                                  TetrahedralizeInfo* info);

}  // namespace shapemap

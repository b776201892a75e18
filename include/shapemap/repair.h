// Safe repairs of input surfaces (real meshes: non-manifold edges and vertices, duplicate
// vertices, degenerate faces, floating pieces, small holes), with the correspondence that
// carries results back to the user's vertex and face numbering. docs/methods.md, "Input
// repairs".
#pragma once
#include "shapemap/maps.h"
#include "shapemap/mesh.h"
#include <string>
#include <vector>

namespace shapemap {

struct SurfaceRepairOptions {
  // Refuse instead of repairing: InputError("<name>: <defects> (--strict: not repaired)").
  bool strict = false;
  // A hole is filled when a disk with its perimeter L (area L^2 / 4 pi) would cover at most
  // this fraction of the surface's area: scale and resolution free; scan holes are small, an
  // open surface's rim is not.
  double max_hole_area = 0.02;
  // Components other than the largest (by area) are set aside only when together they hold
  // at most this fraction of the area; two large pieces are an error, not a repair.
  double max_set_aside_area = 0.1;
};

// The repaired surface and how it relates to the input (n_in vertices, m_in faces).
struct SurfaceRepair {
  TriMesh mesh;                  // the repaired surface, outward oriented (n × 3, m × 3)
  Eigen::VectorXi vertex_from;   // n: input vertex each vertex comes from (split copies share it); -1: added (hole filling)
  Eigen::VectorXi face_from;     // m: input face each face comes from (same corner positions); -1: added (hole filling)
  Eigen::VectorXi input_vertex;  // n_in: the vertex that carries input vertex i, or -1 (set aside or removed)
  // n_in rows, arity 3: the point of `mesh` each input vertex stands for: its own vertex
  // (a unit barycentric row), else the nearest point of the kept surface.
  BarycentricMap input_on_repaired;
  std::vector<std::string> notes;  // one line per change, "<name>: note: ..."; empty: nothing changed
  bool changed() const { return !notes.empty(); }
};

// Repairs `in` (named `name` in the notes and errors) with CGAL's Polygon Mesh Processing:
// duplicate vertices (identical positions) merged; faces with a repeated vertex, duplicated
// faces and zero-area faces removed; non-manifold edges and vertices split; unreferenced
// vertices and components other than the largest set aside; small holes filled. A clean
// surface comes back unchanged (identity correspondence, no notes). What cannot be repaired
// (a large hole, genus, NaN) is left for the input guards (checks.h) to report.
SurfaceRepair repair_surface(const TriMesh& in, const std::string& name, const SurfaceRepairOptions& opt = {});

// The identity correspondence of a surface that needs no repair.
SurfaceRepair identity_repair(const TriMesh& in);

// The defects repair_surface() would change, one phrase each ("3 non-manifold edges (more
// than 2 faces)", ...); empty for a clean surface.
std::vector<std::string> repairable_defects(const TriMesh& in);

// A map M computed from repaired surface rA.mesh to repaired surface rB.mesh (rows:
// rA.mesh vertices, elements: rB.mesh faces), expressed in the users' numbering: one row
// per input vertex of A (split copies and merged duplicates share their vertex's row; set-
// aside vertices map like their nearest point on the kept surface), elements are faces of
// inputB (the image in a hole-filling face moves to the nearest kept input face).
BarycentricMap map_to_inputs(const BarycentricMap& M, const SurfaceRepair& rA, const SurfaceRepair& rB,
                             const TriMesh& inputB);

// The reverse: a map in the users' numbering (rows: input vertices of A, elements: faces of
// inputB) on the repaired surfaces (rows: rA.mesh vertices, elements: rB.mesh faces). Added
// vertices take the row of the nearest original vertex (mesh hops); images on removed faces
// move to the nearest point of rB.mesh.
BarycentricMap map_to_repaired(const BarycentricMap& M, const SurfaceRepair& rA, const SurfaceRepair& rB,
                               const TriMesh& inputB);

// The vertex of r.mesh that input vertex i stands for (its own, else the nearest corner of
// its nearest point).
int repaired_vertex(const SurfaceRepair& r, int i);

}  // namespace shapemap

namespace shapemap {

// Tet meshes whose parts touch along an edge or at a vertex only (their boundary surface is
// non-manifold there): every vertex whose incident tets fall into several groups connected
// through shared triangles gets one new copy per extra group, appended after the existing
// vertices (so rows 0..n-1 stay the user's vertices) and used by that group's tets.
// T: m×4 (rewritten in place), V: n×3 (grows by the number of copies, which is returned).
int split_pinched_tet_vertices(TetMesh& mesh);

}  // namespace shapemap

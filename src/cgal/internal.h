// Internal helpers shared by the files of src/cgal (not a public interface).
// Only tetrahedralize.cpp and implicit_mesher.cpp include CGAL; everything declared
// here takes and returns plain Eigen data.
#pragma once
#include "shapemap/mesh.h"
#include <Eigen/Core>
#include <functional>
#include <string>
#include <vector>

namespace shapemap::cgal_internal {

// Throws InputError("<name>: <problem>") unless F is a closed, edge-manifold,
// vertex-manifold, consistently oriented triangle surface with finite coordinates and
// no degenerate (repeated-index) faces. Used as the input guard of the CGAL meshers
// (independent of checks.h so that src/cgal depends only on mesh.h).
void require_closed_manifold(const TriMesh& mesh, const std::string& name);

// Closed-surface facts computed without CGAL: Euler characteristic, edge-manifold,
// closed, consistently oriented, number of connected components.
struct SurfaceTopology {
  bool closed = false, edge_manifold = false, vertex_manifold = false, oriented = false;
  int components = 0, euler = 0;
  bool genus0() const {
    return closed && edge_manifold && vertex_manifold && oriented && components == 1 && euler == 2;
  }
};
SurfaceTopology surface_topology(const TriMesh& mesh);

// Drops vertices not referenced by F and renumbers F.
void compact_vertices(TriMesh& mesh);

// Remeshes a closed surface with CGAL Mesh_3 (polyhedral domain, facet criteria only,
// manifold topology). facet_size: bound on the surface Delaunay ball radius;
// facet_distance: bound on the distance between a facet's circumcenter and the
// input surface. Every output vertex lies on the input surface (up to round-off).
// Implemented in tetrahedralize.cpp (shares its CGAL instantiation).
TriMesh remesh_surface(const TriMesh& surface, double facet_size, double facet_distance,
                       unsigned seed);

// Meshes the zero level set of f (f < 0 inside) inside the ball (center, radius) with
// CGAL Mesh_3 (Labeled_mesh_domain_3, facet criteria only, manifold topology).
// initial_segments: short segments (inside point, outside point) crossing the surface
// once, at least one per part of the shape, well separated (about a facet size apart:
// close initial points make Delaunay refinement cascade around them). Their crossings
// are the initial surface vertices. Output outward oriented.
// Implemented in implicit_mesher.cpp.
struct ImplicitSurface {
  std::function<double(const Eigen::Vector3d&)> f;
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  double radius = 1;
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> initial_segments;
};
TriMesh mesh_implicit_surface(const ImplicitSurface& s, double facet_size,
                              double facet_distance, unsigned seed);

}  // namespace shapemap::cgal_internal

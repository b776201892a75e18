// A shapemap triangle surface as a CGAL Surface_mesh (Epick points), shared by the CGAL
// translation units that hand surfaces to CGAL (tetrahedralize.cpp, self_intersections.cpp).
#pragma once
#include "shapemap/error.h"
#include "shapemap/mesh.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Surface_mesh.h>

#include <string>
#include <vector>

namespace shapemap::cgal_internal {

using SurfaceMesh = CGAL::Surface_mesh<CGAL::Exact_predicates_inexact_constructions_kernel::Point_3>;

// Throws InputError("<name>: face <f> breaks manifoldness") when CGAL refuses a face.
inline SurfaceMesh to_surface_mesh(const TriMesh& m, const std::string& name) {
  using Point = SurfaceMesh::Point;
  SurfaceMesh sm;
  std::vector<SurfaceMesh::Vertex_index> vi(m.num_vertices());
  for (int i = 0; i < m.num_vertices(); ++i) vi[i] = sm.add_vertex(Point(m.V(i, 0), m.V(i, 1), m.V(i, 2)));
  for (int f = 0; f < m.num_faces(); ++f)
    if (sm.add_face(vi[m.F(f, 0)], vi[m.F(f, 1)], vi[m.F(f, 2)]) == SurfaceMesh::null_face())
      throw InputError(name + ": face " + std::to_string(f) + " breaks manifoldness");
  return sm;
}

}  // namespace shapemap::cgal_internal

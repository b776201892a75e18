// The boundary surface of a CGAL Mesh_3 complex, shared by the two CGAL translation
// units (tetrahedralize.cpp, implicit_mesher.cpp). Include after the Mesh_3 headers.
#pragma once
#include "shapemap/mesh.h"
#include <array>
#include <unordered_map>
#include <utility>
#include <vector>

namespace shapemap::cgal_internal {

// Facets in the complex, oriented with the inside cell behind them (outward normals),
// vertices numbered in order of first use.
template <class C3t3>
TriMesh complex_boundary_surface(const C3t3& c3t3) {
  using Tr = typename C3t3::Triangulation;
  using Vertex_handle = typename Tr::Vertex_handle;
  std::unordered_map<Vertex_handle, int> index;
  std::vector<Eigen::Vector3d> pts;
  std::vector<std::array<int, 3>> faces;
  const Tr& tr = c3t3.triangulation();
  for (auto f = c3t3.facets_in_complex_begin(); f != c3t3.facets_in_complex_end(); ++f) {
    typename Tr::Cell_handle c = f->first;
    int i = f->second;
    if (!c3t3.is_in_complex(c)) {
      typename Tr::Facet mf = tr.mirror_facet(*f);
      c = mf.first, i = mf.second;
    }
    std::array<Vertex_handle, 3> vh;
    for (int j = 0; j < 3; ++j) vh[j] = c->vertex(Tr::vertex_triple_index(i, j));
    // The inside vertex c->vertex(i) must lie below the triangle.
    if (CGAL::orientation(vh[0]->point().point(), vh[1]->point().point(), vh[2]->point().point(),
                          c->vertex(i)->point().point()) == CGAL::POSITIVE)
      std::swap(vh[1], vh[2]);
    std::array<int, 3> t;
    for (int j = 0; j < 3; ++j) {
      auto [it, inserted] = index.emplace(vh[j], int(pts.size()));
      if (inserted) {
        const auto& q = vh[j]->point().point();
        pts.emplace_back(CGAL::to_double(q.x()), CGAL::to_double(q.y()), CGAL::to_double(q.z()));
      }
      t[j] = it->second;
    }
    faces.push_back(t);
  }
  TriMesh out;
  out.V.resize(Eigen::Index(pts.size()), 3);
  for (size_t i = 0; i < pts.size(); ++i) out.V.row(Eigen::Index(i)) = pts[i].transpose();
  out.F.resize(Eigen::Index(faces.size()), 3);
  for (size_t i = 0; i < faces.size(); ++i) out.F.row(Eigen::Index(i)) << faces[i][0], faces[i][1], faces[i][2];
  return out;
}

}  // namespace shapemap::cgal_internal

// CGAL's Mesh_3 writes dump-bug.mesh and dump-bug.binary.cgal (tens of MB) into the working
// directory when one of its errors fires (measured: a noisy sphere whose creases Mesh_3
// could not refine). shapemap reports the error instead, so each CGAL translation unit
// replaces the dump for its complex type: SHAPEMAP_NO_C3T3_DUMP(shapemap::C3t3), at global
// scope after the Mesh_3 headers and before the first mesher call.
#include <CGAL/Mesh_3/Dump_c3t3.h>
#define SHAPEMAP_NO_C3T3_DUMP(C3T3)                                       \
  namespace CGAL {                                                        \
  template <>                                                             \
  struct Dump_c3t3<C3T3, true> {                                          \
    void dump_c3t3(const C3T3&, std::string) const {}                     \
  };                                                                      \
  template <>                                                             \
  struct Dump_c3t3<C3T3, false> {                                         \
    void dump_c3t3(const C3T3&, std::string) const {}                     \
  };                                                                      \
  }

// Surface meshing of an implicit function with CGAL Mesh_3 (Labeled_mesh_domain_3,
// facet criteria only, manifold topology). One of the two translation units of
// shapemap that include CGAL (the other: tetrahedralize.cpp).
#include "internal.h"
#include "shapemap/error.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Labeled_mesh_domain_3.h>
#include <CGAL/Mesh_complex_3_in_triangulation_3.h>
#include <CGAL/Mesh_criteria_3.h>
#include <CGAL/Mesh_triangulation_3.h>
#include <CGAL/Random.h>
#include <CGAL/refine_mesh_3.h>
#include "c3t3_surface.h"  // after the CGAL headers it instantiates

#include <array>
#include <unordered_map>

namespace shapemap::cgal_internal {
namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = K::Point_3;
using Domain = CGAL::Labeled_mesh_domain_3<K>;
using Tr = CGAL::Mesh_triangulation_3<Domain, CGAL::Default, CGAL::Sequential_tag>::type;
using C3t3 = CGAL::Mesh_complex_3_in_triangulation_3<Tr>;
using Criteria = CGAL::Mesh_criteria_3<Tr>;
using Vertex_handle = Tr::Vertex_handle;
}  // namespace
}  // namespace shapemap::cgal_internal
SHAPEMAP_NO_C3T3_DUMP(shapemap::cgal_internal::C3t3)
namespace shapemap::cgal_internal {
namespace {

}  // namespace

TriMesh mesh_implicit_surface(const ImplicitSurface& s, double facet_size, double facet_distance,
                              unsigned seed) {
  if (!s.f) throw Error("mesh_implicit_surface: no function");
  CGAL::get_default_random() = CGAL::Random(seed);
  CGAL::Random rng(seed);
  auto fn = [&s](const Point& p) { return s.f(Eigen::Vector3d(p.x(), p.y(), p.z())); };
  namespace P = CGAL::parameters;
  Domain domain = Domain::create_implicit_mesh_domain(
      fn, K::Sphere_3(Point(s.center.x(), s.center.y(), s.center.z()), s.radius * s.radius),
      P::relative_error_bound = 1e-7, P::p_rng = &rng);
  Criteria criteria(P::facet_angle = 30, P::facet_size = facet_size,
                    P::facet_distance = facet_distance);

  // Initial points: the crossings of the given segments (computed by the domain, so
  // they carry its surface index).
  C3t3 c3t3;
  auto intersect = domain.construct_intersection_object();
  auto cwp = c3t3.triangulation().geom_traits().construct_weighted_point_3_object();
  int inserted = 0;
  for (const auto& [a, b] : s.initial_segments) {
    Domain::Intersection in = intersect(K::Segment_3(Point(a.x(), a.y(), a.z()), Point(b.x(), b.y(), b.z())));
    if (std::get<2>(in) == 0) continue;
    Vertex_handle v = c3t3.triangulation().insert(cwp(std::get<0>(in)));
    if (v != Vertex_handle()) {
      c3t3.set_dimension(v, 2);
      c3t3.set_index(v, std::get<1>(in));
      ++inserted;
    }
  }
  if (inserted < 4) throw Error("mesh_implicit_surface: could not place initial points");
  CGAL::refine_mesh_3(c3t3, domain, criteria, P::no_perturb(), P::no_exude(), P::no_odt(),
                      P::no_lloyd(), P::no_reset_c3t3(), P::manifold());

  return complex_boundary_surface(c3t3);
}

}  // namespace shapemap::cgal_internal

// Generated shapes and pairs with ground truth (no data set can be downloaded).
#pragma once
#include "shapemap/maps.h"
#include "shapemap/mesh.h"
#include <cstdint>
#include <functional>
#include <string>

namespace shapemap {

// Simple shapes, closed and outward oriented, about `target_vertices` vertices.
TriMesh make_sphere(int target_vertices, double radius = 1.0);          // icosphere-like
TriMesh make_ellipsoid(int target_vertices, const Eigen::Vector3d& radii);
TriMesh make_torus(int target_vertices, double R = 1.0, double r = 0.35);  // genus 1
TriMesh make_cube_sphere(int target_vertices);                          // cube projected to sphere

// A smooth spatial deformation R^3 -> R^3 (used for ground truth of surfaces and volumes).
struct Deformation {
  std::function<Eigen::Vector3d(const Eigen::Vector3d&)> apply;
};

// "Creature": a smooth implicit union of primitives (body, four legs, neck and head,
// tail), randomized by seed, meshed with CGAL to about target_vertices vertices.
TriMesh make_creature(std::uint64_t seed, int target_vertices);

enum class PairKind { NearIsometric, NonIsometric };

// A deformation of the creature of `seed`: limb bending around joints (both kinds),
// plus stretching and local scaling (NonIsometric).
Deformation creature_deformation(std::uint64_t seed, PairKind kind);

struct GeneratedPair {
  TriMesh A, B;                // B is a remeshing of deform(A) to a different tessellation
  BarycentricMap truth_AB;     // each vertex of A -> face of B + barycentric
  BarycentricMap truth_BA;     // each vertex of B -> face of A + barycentric
  Deformation deformation;     // A-space -> B-space
};

// B is CGAL Mesh_3 surface remeshing (polyhedral domain of deform(A), facet criteria
// only, manifold) at a size for about target_vertices: its vertices lie on deform(A)
// (so truth_BA is exact to round-off) and truth_AB is within the remeshing error
// (facet distance, ~0.15% of the bounding-box diagonal). Deterministic for a seed.
GeneratedPair make_creature_pair(std::uint64_t seed, PairKind kind, int target_vertices);

}  // namespace shapemap

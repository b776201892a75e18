// Validity reports of surfaces and volumes, and the guards the methods use on input.
#pragma once
#include "shapemap/mesh.h"
#include <string>
#include <vector>

namespace shapemap {

struct MeshReport {
  int num_vertices = 0, num_elements = 0;
  bool finite = true;                 // no NaN/Inf coordinates
  bool indices_in_range = true;       // every index in [0, n)
  int unreferenced_vertices = 0;
  int duplicate_vertices = 0;         // exactly coincident positions
  int degenerate_elements = 0;        // zero area / volume, or repeated indices
  int inverted_elements = 0;          // tets only: negative volume
  int non_manifold_edges = 0;         // surfaces: edges with > 2 faces
  int non_manifold_vertices = 0;      // surfaces: vertex whose link is not one fan/cycle
  int boundary_edges = 0;             // surfaces: edges with 1 face
  bool closed = false;
  bool consistently_oriented = true;
  int components = 0;
  int euler_characteristic = 0;       // surfaces; for tets: of the boundary surface
  int genus = -1;                     // (2 - chi)/2 for closed connected surfaces, else -1
  int boundary_components = 0;        // tets: connected components of the boundary surface
  std::vector<std::string> problems;  // human-readable, one per failed check
  bool ok() const { return problems.empty(); }
};

MeshReport check_surface(const TriMesh& mesh);
MeshReport check_volume(const TetMesh& mesh);

// "1 hole", "3 holes": the counts of the problems lines.
std::string plural(long long n, const std::string& one, const std::string& many);
// The problems lines of the surface defects the safe repairs fix (duplicate vertices,
// degenerate faces, non-manifold edges and vertices), in that order, appended to `out`.
void append_repairable_problems(const MeshReport& r, std::vector<std::string>& out);

// Throws InputError("<name>: <problem>") unless the surface is closed, manifold,
// connected, genus 0, finite, with at least min_vertices vertices. Orients the
// faces consistently outward when they are consistent but inward.
void require_genus0_surface(TriMesh& mesh, const std::string& name, int min_vertices = 100);

// Throws InputError unless the tet mesh is finite, in range, connected, with at most
// max_bad_fraction of degenerate or inverted tets.
void require_valid_volume(const TetMesh& mesh, const std::string& name,
                          double max_bad_fraction = 0.01);

// Throws InputError unless the tet mesh is a topological ball (one boundary
// component, boundary genus 0, connected).
void require_ball_topology(const TetMesh& mesh, const std::string& name);

// Flips faces (consistently oriented input) so the enclosed volume is positive.
void orient_outward(TriMesh& mesh);

}  // namespace shapemap

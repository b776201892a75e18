// shapemap check MESH [--json]: validity report of a surface (.obj .off .ply .stl) or a
// tetrahedral mesh (.vtk .mesh .msh .node/.ele), chosen by extension. Prints the report
// on stdout; exit 0 if the mesh has no problems, 2 if it has problems or cannot be read
// (then one line on stderr names the file and what is wrong).
#include "common.h"
#include "shapemap/checks.h"
#include "shapemap/error.h"
#include "shapemap/io.h"
#include "shapemap/volume/tetrahedralize.h"
#include <iostream>

namespace shapemap::cli {

namespace {

nlohmann::json report_json(const std::string& path, bool volume, const MeshReport& r) {
  nlohmann::json j;
  j["path"] = path;
  j["kind"] = volume ? "volume" : "surface";
  j["ok"] = r.ok();
  j["num_vertices"] = r.num_vertices;
  j[volume ? "num_tets" : "num_faces"] = r.num_elements;
  j["finite"] = r.finite;
  j["indices_in_range"] = r.indices_in_range;
  j["unreferenced_vertices"] = r.unreferenced_vertices;
  j["duplicate_vertices"] = r.duplicate_vertices;
  j["degenerate_elements"] = r.degenerate_elements;
  if (volume) j["inverted_elements"] = r.inverted_elements;
  j["non_manifold_edges"] = r.non_manifold_edges;
  j["non_manifold_vertices"] = r.non_manifold_vertices;
  j["boundary_edges"] = r.boundary_edges;
  j["closed"] = r.closed;
  j["consistently_oriented"] = r.consistently_oriented;
  j["components"] = r.components;
  j["euler_characteristic"] = r.euler_characteristic;
  j["genus"] = r.genus;
  j["boundary_components"] = r.boundary_components;
  j["problems"] = r.problems;
  return j;
}

void print_text(const std::string& path, bool volume, const MeshReport& r) {
  auto yes = [](bool b) { return b ? "yes" : "no"; };
  std::cout << path << ": " << (volume ? "tetrahedral mesh" : "surface") << ", " << r.num_vertices << " vertices, "
            << r.num_elements << (volume ? " tetrahedra" : " faces") << "\n";
  std::cout << "  finite coordinates      " << yes(r.finite) << "\n";
  std::cout << "  indices in range        " << yes(r.indices_in_range) << "\n";
  std::cout << "  unreferenced vertices   " << r.unreferenced_vertices << "\n";
  std::cout << "  duplicate vertices      " << r.duplicate_vertices << "\n";
  std::cout << "  degenerate " << (volume ? "tetrahedra   " : "faces        ") << r.degenerate_elements << "\n";
  if (volume) std::cout << "  inverted tetrahedra     " << r.inverted_elements << "\n";
  const char* b = volume ? "  boundary " : "  ";
  std::cout << b << "non-manifold edges      " << r.non_manifold_edges << "\n";
  std::cout << b << "non-manifold vertices   " << r.non_manifold_vertices << "\n";
  if (!volume) std::cout << "  boundary edges          " << r.boundary_edges << "\n";
  std::cout << "  closed                  " << yes(r.closed) << "\n";
  std::cout << "  consistently oriented   " << yes(r.consistently_oriented) << "\n";
  std::cout << "  connected components    " << r.components << "\n";
  std::cout << (volume ? "  boundary Euler char.    " : "  Euler characteristic    ") << r.euler_characteristic
            << "\n";
  std::cout << (volume ? "  boundary genus          " : "  genus                   ");
  if (r.genus >= 0) std::cout << r.genus << "\n";
  else std::cout << "undefined (not a closed connected manifold)\n";
  std::cout << (volume ? "  boundary components     " : "  boundary loops          ") << r.boundary_components
            << "\n";
  if (r.ok()) {
    std::cout << "  problems                none\n";
  } else {
    std::cout << "  problems:\n";
    for (auto& p : r.problems) std::cout << "    - " << p << "\n";
  }
}

}  // namespace

Command register_check(CLI::App& app, GlobalOptions& g) {
  Command c;
  c.app = app.add_subcommand("check", "Validity report of a surface or tetrahedral mesh");
  auto path = std::make_shared<std::string>();
  auto json = std::make_shared<bool>(false);
  c.app->add_option("MESH", *path, "Surface (.obj .off .ply .stl) or tet mesh (.vtk .mesh .msh .node/.ele)")
      ->required();
  c.app->add_flag("--json", *json, "Print the report as JSON");
  c.run = [path, json] {
    const std::string& p = *path;
    bool volume = is_volume_path(p);
    if (!volume && !is_surface_path(p))
      throw InputError(p + ": unknown mesh format (use .obj .off .ply .stl or .vtk .mesh .msh .node .ele)");
    TriMesh surface;
    if (!volume) surface = read_surface(p);
    MeshReport r = volume ? check_volume(read_volume(p)) : check_surface(surface);
    // Self-intersections of a closed surface (CGAL, exact): tetrahedralization meshes the
    // inside by ray parity, which is not what such a surface was meant to bound.
    int crossings = -1;  // -1: not a closed manifold, not tested
    if (!volume && r.ok()) {
      crossings = self_intersecting_face_pairs(surface);
      if (crossings > 0)
        r.problems.push_back(std::to_string(crossings) + (crossings == 1 ? " pair" : " pairs") +
                             " of faces cross each other (self-intersections)");
    }
    nlohmann::json jr = report_json(p, volume, r);
    if (!volume) jr["self_intersecting_face_pairs"] = crossings;
    if (*json) std::cout << jr.dump(2) << "\n";
    else print_text(p, volume, r);
    if (r.ok()) return 0;
    std::string line = p + ": ";
    for (size_t i = 0; i < r.problems.size(); ++i) line += (i ? "; " : "") + r.problems[i];
    std::cerr << "shapemap: error: " << line << "\n";
    return 2;
  };
  return c;
}

}  // namespace shapemap::cli

// shapemap render: PNG pictures of meshes and maps with the software rasterizer.
#include "common.h"
#include "shapemap/error.h"
#include "shapemap/io.h"
#include "shapemap/render/scenes.h"
#include <cctype>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace shapemap::cli {

namespace {

struct RenderArgs {
  std::string mesh, out, mode = "shaded", scalar, map, target, landmarks, mapped;
  int width = 600, axis = 2;
  bool wireframe = false;
};

Eigen::VectorXd read_scalars(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path + ": cannot open");
  std::vector<double> v;
  std::string line;
  int lineno = 0;
  while (std::getline(in, line)) {
    ++lineno;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ss(line);
    double x;
    if (!(ss >> x)) throw InputError(path + ":" + std::to_string(lineno) + ": expected a number");
    v.push_back(x);
  }
  if (v.empty()) throw InputError(path + ": no values");
  return Eigen::Map<Eigen::VectorXd>(v.data(), Eigen::Index(v.size()));
}

TriMesh surface_of(const std::string& path) {
  if (is_volume_path(path)) return boundary_surface(read_volume(path)).surface;
  return read_surface(path);
}

int run_render(const RenderArgs& a, const GlobalOptions& g) {
  {
    std::string ext = std::filesystem::path(a.out).extension().string();
    for (char& ch : ext) ch = char(std::tolower(static_cast<unsigned char>(ch)));
    if (ext != ".png") throw InputError(a.out + ": the output is a PNG picture; name it *.png");
  }
  SceneOptions so;
  so.render.width = so.render.height = a.width;
  so.wireframe = a.wireframe;
  Image img;
  if (a.mode == "shaded") {
    img = render_mesh(surface_of(a.mesh), so);
  } else if (a.mode == "scalar") {
    if (a.scalar.empty()) throw InputError("render --mode scalar needs --scalar FILE");
    img = render_scalar(surface_of(a.mesh), read_scalars(a.scalar), "value", so);
  } else if (a.mode == "texture" || a.mode == "normals") {
    if (a.map.empty() || a.target.empty()) throw InputError("render --mode " + a.mode + " needs --map MAP --target B");
    TriMesh A = read_surface(a.mesh), B = read_surface(a.target);
    BarycentricMap m = read_map(a.map);
    validate_map(m, A.num_vertices(), B.num_faces(), 3, a.map);
    img = a.mode == "texture" ? render_texture_transfer(A, B, map_positions(m, B.V, B.F), so)
                              : render_normal_transfer(A, B, m, so);
  } else if (a.mode == "landmarks") {
    if (a.landmarks.empty()) throw InputError("render --mode landmarks needs --landmarks FILE");
    TriMesh A = read_surface(a.mesh);
    img = render_landmarks(A, read_landmarks(a.landmarks, A.V), so);
  } else if (a.mode == "slices" || a.mode == "ball") {
    if (a.mapped.empty()) throw InputError("render --mode " + a.mode + " needs --mapped FILE (A_on_B.vtk or ball.vtk)");
    TetMesh A = read_volume(a.mesh), X = read_volume(a.mapped);
    if (X.V.rows() != A.V.rows())
      throw InputError(a.mapped + ": " + std::to_string(X.V.rows()) + " vertices, but " + a.mesh + " has " +
                       std::to_string(A.V.rows()));
    img = a.mode == "slices" ? render_volume_slices(A, X.V, a.axis, so) : render_ball(A, X.V, so);
  } else {
    throw InputError("render: unknown --mode '" + a.mode + "'");
  }
  write_png(a.out, img);
  info(g, "wrote " + a.out);
  return 0;
}

CLI::App* add_render_command(CLI::App& parent, RenderArgs& a) {
  CLI::App* app = parent.add_subcommand("render", "PNG pictures of meshes and maps (headless software rasterizer)");
  app->add_option("mesh", a.mesh, "Mesh to draw (surface or tet mesh; the source for maps)")->required();
  app->add_option("-o,--output", a.out, "Output PNG")->required();
  app->add_option("--mode", a.mode,
                  "shaded | scalar (--scalar) | texture, normals (--map --target) | landmarks (--landmarks) | "
                  "slices (--mapped A_on_B.vtk) | ball (--mapped ball.vtk)")
      ->check(CLI::IsMember({"shaded", "scalar", "texture", "normals", "landmarks", "slices", "ball"}));
  app->add_option("--scalar", a.scalar, "One value per vertex or per face, one per line");
  app->add_option("--map", a.map, "Map file from mesh to --target (docs/formats.md)");
  app->add_option("--target", a.target, "Target surface of --map");
  app->add_option("--landmarks", a.landmarks, "Landmark file");
  app->add_option("--mapped", a.mapped, "Tet mesh with the source connectivity and mapped positions");
  app->add_option("--axis", a.axis, "Slicing axis for --mode slices (0, 1, 2)")->check(CLI::Range(0, 2));
  app->add_option("--width", a.width, "Image width and height in pixels")->check(CLI::Range(16, 8192));
  app->add_flag("--wireframe", a.wireframe, "Draw triangle edges");
  return app;
}

}  // namespace

Command register_render(CLI::App& app, GlobalOptions& g) {
  return args_command<RenderArgs>(app, g, add_render_command, run_render);
}

}  // namespace shapemap::cli

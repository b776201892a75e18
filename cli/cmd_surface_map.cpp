// shapemap surface-map A B -o OUT [--method bim|elastic] [--init bim|FILE]
//                                 [--landmarks LA LB] [--symmetric]
// Map between two closed genus-0 surfaces. Writes into OUT (DESIGN.md contract):
//   map_AB.txt (map_BA.txt with --symmetric), A_on_B.obj (B_on_A.obj), report.json.
// --method bim: Blended Intrinsic Maps (src/surface/bim.cpp); with --landmarks the
//   candidate Möbius maps are the triplets of the given correspondences.
// --method elastic: elastic correspondence refinement (src/surface/elastic.cpp) of an
//   initial map from BIM (--init bim, default) or from a map file (--init FILE).
#include "common.h"
#include "shapemap/checks.h"
#include "shapemap/error.h"
#include "shapemap/io.h"
#include "shapemap/maps.h"
#include "shapemap/surface/bim.h"
#include "shapemap/surface/surface_map_pipeline.h"
#include "figures.h"
#include "surface_map_elastic.h"
#include <filesystem>

namespace shapemap::cli {

namespace {

struct SurfaceMapArgs {
  std::string A, B, out;
  std::string method = "bim";
  std::string init = "bim";
  std::vector<std::string> landmarks;  // LA LB
  bool symmetric = false;
  // --features, --candidates, --samples, --reverse-candidates; the rest as BIMOptions has them.
  BIMOptions bim;
  ElasticSettings elastic;  // --elastic-* (surface_map_elastic.cpp)
  std::string truth_ab;     // --truth
};

BIMOptions bim_options(const SurfaceMapArgs& a, const GlobalOptions& g) {
  BIMOptions o = a.bim;
  o.seed = g.seed;
  o.name_A = a.A;
  o.name_B = a.B;
  return o;
}

// --init for the elastic method: "bim", a map file (A -> B), or a folder with map_AB.txt
// [map_BA.txt]; the maps are in the numbering of the files given.
void read_init_maps(const std::string& init, const TriMesh& A, const TriMesh& B, SurfaceMapRequest& req) {
  namespace fs = std::filesystem;
  if (init.empty() || init == "bim") return;
  if (fs::is_directory(init)) {
    const std::string ab = (fs::path(init) / "map_AB.txt").string();
    const std::string ba = (fs::path(init) / "map_BA.txt").string();
    if (!fs::exists(ab)) throw InputError(init + ": no map_AB.txt in this folder");
    req.init_AB = read_checked_map(ab, A.num_vertices(), B.num_faces());
    req.init_description = "file " + ab;
    if (fs::exists(ba)) {
      req.init_BA = read_checked_map(ba, B.num_vertices(), A.num_faces());
      req.init_description = "files " + ab + ", " + ba;
    }
    return;
  }
  if (!fs::exists(init)) throw InputError(init + ": no such file (--init bim|FILE)");
  req.init_AB = read_checked_map(init, A.num_vertices(), B.num_faces());
  req.init_description = "file " + init;
}

// The request of the library call from the command line: landmarks and maps read from
// their files, in the numbering of the input surfaces.
SurfaceMapRequest make_request(const SurfaceMapArgs& a, const GlobalOptions& g, const TriMesh& A, const TriMesh& B) {
  if (a.method == "bim" && a.init != "bim")
    throw InputError("--init " + a.init + ": an initial map is only used by --method elastic");
  SurfaceMapRequest req;
  req.method = a.method;
  req.symmetric = a.symmetric;
  req.strict = g.strict;
  req.bim = bim_options(a, g);
  req.elastic = a.elastic;
  if (a.symmetric && a.method == "elastic" && a.elastic.injective)
    throw InputError("--symmetric: the injective model (--elastic-injective, Eq. 4) maps A -> B only");
  if (!a.landmarks.empty()) {
    if (a.landmarks.size() != 2) throw InputError("--landmarks: needs two files, LA and LB");
    req.bim.landmarks_A = read_landmarks(a.landmarks[0], A.V);
    req.bim.landmarks_B = read_landmarks(a.landmarks[1], B.V);
    for (const std::string& n : tidy_landmark_pairs(req.bim.landmarks_A, req.bim.landmarks_B, a.landmarks[0],
                                                    a.landmarks[1]))
      info(g, n);
    if (a.method == "bim" && req.bim.landmarks_A.size() < 3)
      throw InputError(a.landmarks[0] + ": at least 3 landmarks are needed");
  }
  if (!a.truth_ab.empty()) req.truth_AB = read_checked_map(a.truth_ab, A.num_vertices(), B.num_faces());
  if (a.method == "elastic" && a.landmarks.empty()) read_init_maps(a.init, A, B, req);
  return req;
}

int run_surface_map_command(const SurfaceMapArgs& a, const GlobalOptions& g) {
  StageTimer timer;
  timer.start("read");
  const TriMesh A = read_surface(a.A), B = read_surface(a.B);
  const SurfaceMapRequest req = make_request(a, g, A, B);
  OutputDir out(a.out);
  timer.start(a.method);
  if (a.method == "bim") info(g, "surface-map: Blended Intrinsic Maps " + a.A + " -> " + a.B);
  const SurfaceMapRun r = run_surface_map(A, B, req, make_progress(g));
  for (const std::string& n : r.notes) info(g, n);
  timer.start("write");
  write_map(out.path("map_AB.txt"), r.AB);
  write_surface(out.path("A_on_B.obj"), TriMesh{map_positions(r.AB, B.V, B.F), A.F});
  if (r.has_BA()) {
    write_map(out.path("map_BA.txt"), r.BA);
    write_surface(out.path("B_on_A.obj"), TriMesh{map_positions(r.BA, A.V, A.F), B.F});
  }
  nlohmann::json j = report_header(g, "surface-map");
  j.update(r.report);
  j["inputs"]["A"] = a.A;
  j["inputs"]["B"] = a.B;
  if (!a.landmarks.empty()) j["inputs"]["landmarks"] = a.landmarks;
  if (!a.truth_ab.empty()) j["inputs"]["truth"] = a.truth_ab;
  timer.start("pictures");
  const TriMesh &RA = r.repair_A.mesh, &RB = r.repair_B.mesh;
  const BarycentricMap* BA = r.has_BA() ? &r.BA_repaired : nullptr;
  const auto figures = surface_map_figures(RA, RB, r.AB_repaired, BA);
  const ViewerData viewer = surface_map_viewer_data(RA, RB, r.AB_repaired, BA, r.landmarks_A, r.landmarks_B,
                                                    &r.error_AB);
  timer.stop();
  j["timings"] = timer.json();
  write_reports(out, j, "shapemap surface-map --method " + a.method, figures, &viewer, &g);
  out.commit();
  info(g, r.summary + ", " + std::to_string(timer.total()) + " s; wrote " + a.out);
  for (const std::string& w : r.warnings) info(g, w);
  return 0;
}

CLI::App* add_surface_map_command(CLI::App& parent, SurfaceMapArgs& a) {
  CLI::App* app =
      parent.add_subcommand("surface-map", "Map between two closed genus-0 surfaces (BIM, elastic refinement)");
  add_pair_options(app, a.A, a.B, a.out, "Source surface (.obj .off .ply .stl)", "Target surface");
  app->add_option("--method", a.method, "bim (Blended Intrinsic Maps) or elastic (refinement)")
      ->check(CLI::IsMember({"bim", "elastic"}));
  app->add_option("--init", a.init,
                  "elastic: initial map, 'bim', a map file (map_AB.txt format) or a folder with "
                  "map_AB.txt [map_BA.txt]");
  app->add_option("--landmarks", a.landmarks,
                  "LA LB: corresponding landmark lists (one 0-based vertex index or one x y z point per line)")
      ->expected(2);
  app->add_flag("--symmetric", a.symmetric,
                "BIM: also compute the map B -> A (the elastic bijective model always does; "
                "not with --elastic-injective)");
  app->add_flag("--reverse-candidates,!--no-reverse-candidates", a.bim.reverse_candidates,
                "BIM with --symmetric (and elastic's BIM init): the direction with the less confident "
                "blend takes the inverse of the other direction's blend (the default; "
                "--no-reverse-candidates keeps each direction's own blend)");
  app->add_flag("--landmark-features,!--no-landmark-features", a.bim.landmark_feature_points,
                "BIM with --landmarks: the AGD maxima away from the landmarks are feature points too, "
                "and candidates from them are kept when they carry every landmark near its partner "
                "(the default; docs/methods.md, \"Landmarks among the feature points\"); "
                "--no-landmark-features: the landmark triples alone");
  app->add_option("--landmark-agreement", a.bim.landmark_agreement,
                  "BIM with --landmarks: a candidate that is not a landmark triple must carry every landmark "
                  "within this geodesic distance of its partner (unit-area target; default 0.35)")
      ->check(CLI::PositiveNumber);
  app->add_option("--features", a.bim.max_features, "BIM: at most this many AGD feature points per surface")
      ->check(CLI::Range(3, 30));
  app->add_option("--min-features", a.bim.min_features,
                  "BIM: fewer AGD maxima than this on a surface: add evenly spread samples up to it")
      ->check(CLI::Range(3, 30));
  app->add_option("--blend-features", a.bim.blend_min_features,
                  "BIM without landmarks: when no two candidate maps can be blended (3 features on a surface), "
                  "run again with evenly spread samples added up to this many features a side, guided by a "
                  "single map's triple, and keep that blend when it is more confident (default 12; 0: off; "
                  "docs/methods.md, \"Too few features to blend\")")
      ->check(CLI::Range(0, 30));
  app->add_option("--blend-triples", a.bim.blend_retry_triples,
                  "BIM, that second run: once for each of this many most confident single maps' triples; the "
                  "most confident blend is kept (default 1: the best single map's only; docs/methods.md)")
      ->check(CLI::Range(1, 20));
  app->add_option("--blend-guide-maps", a.bim.blend_guide_maps,
                  "BIM, when no such run is more confident than the single map: one more run, guided by the "
                  "least stretched (membrane energy W_mem, elastic Eq. 7) of this many most confident candidate "
                  "maps on the spread samples when it is less stretched than every single map, kept when it blends "
                  "(default 32; 0: off; docs/methods.md, \"Too few features to blend: the stretch guide\")")
      ->check(CLI::Range(0, 10000));
  app->add_option("--blend-agreement", a.bim.blend_agreement,
                  "BIM, that second run: a candidate must carry its guiding triple within this geodesic "
                  "distance of its partners (unit-area target; default 1.0)")
      ->check(CLI::PositiveNumber);
  app->add_option("--feature-radius", a.bim.feature_radius,
                  "BIM: an AGD maximum must be the largest within this geodesic radius (unit-area surface)")
      ->check(CLI::PositiveNumber);
  app->add_option("--candidates", a.bim.max_candidates, "BIM: at most this many candidate Möbius maps")
      ->check(CLI::PositiveNumber);
  app->add_option("--candidate-pool", a.bim.candidate_pool,
                  "BIM: rank up to this many candidates by mean confidence (Eq. 2) and keep the best "
                  "--candidates of them; 0: Sec. 6.2's random removal alone")
      ->check(CLI::NonNegativeNumber);
  app->add_option("--implied-radius", a.bim.implied_radius,
                  "BIM: a map also stands for the feature pairs it implies (a source feature mapped "
                  "within this geodesic distance of a target feature, unit-area surfaces) in Sec. "
                  "6.2's conflict test; 0: the generating triple alone")
      ->check(CLI::NonNegativeNumber);
  app->add_option("--matching-search", a.bim.matching_search_sweeps,
                  "BIM: change the selected group's feature matching at most this many times, one "
                  "correspondence or one swap at a time, while the blend within it gains integrated "
                  "confidence (docs/methods.md, \"The matching search\"); 0: Sec. 6.2's groups alone")
      ->check(CLI::NonNegativeNumber);
  app->add_option("--samples", a.bim.num_even, "BIM: |P_even| evenly spread samples")->check(CLI::Range(16, 4096));
  add_elastic_options(app, a.elastic, a.truth_ab);
  return app;
}

}  // namespace

Command register_surface_map(CLI::App& app, GlobalOptions& g) {
  return args_command<SurfaceMapArgs>(app, g, add_surface_map_command, run_surface_map_command);
}

}  // namespace shapemap::cli

// The `--method elastic` branch of `shapemap surface-map` (elastic-correspondence.txt):
// its own options, registered on the surface-map subcommand, and its run function.
// cmd_surface_map.cpp parses A, B, -o, --init, --landmarks and calls run_elastic_surface_map.
#pragma once
#include "common.h"
#include "shapemap/maps.h"
#include "shapemap/surface/bim.h"
#include <string>
#include <vector>

namespace shapemap::cli {

struct ElasticCliOptions {
  std::string preset = "auto";  // auto | non-isometric (eta 0.1) | near-isometric (0.01) | degenerate (0.002)
  double eta = -1;                       // overrides the preset's bending weight (Eq. 2)
  double alpha = 20;                     // membrane weight (Eq. 2)
  int iterations = 300;                  // K, outer iterations (Algorithm 1)
  bool injective = false;                // E_inj (Eq. 4) instead of E_bij (Eq. 6)
  bool partial = false;                  // Sec. 6.2: no unit-area scaling
  std::string truth_ab;                  // ground truth A->B (map file) for the geodesic error
  double beta_start = -1;                // Sec. 5.2 beta ramp start (default: ElasticOptions, 1e3)
  double log_eps = -1;                   // Sec. 4.1 log threshold (default 1e-4; 0 = true barrier)
  bool keep_orientation = false;         // ElasticOptions::keep_orientation
  bool gamma_ramp = false;               // ElasticOptions::gamma_ramp
  bool plain_projection = false;         // ElasticOptions::safe_projection = false
  bool keep_worse = false;               // turn the collapse guard off (ElasticOptions::keep_no_worse)
  int inner_iterations = -1;             // ElasticOptions::inner_max_iterations (default 50)
  double inner_f_tol = -1;               // ElasticOptions::inner_f_tol (default 1e-9)
  double ramp_inner_f_tol = -1;          // ElasticOptions::inner_f_tol_ramp (default 0 = inner_f_tol)
};

// A map file that must map n_source vertices into m_target triangles (exit 2 otherwise).
BarycentricMap read_checked_map(const std::string& path, int n_source, int m_target);

// The surface-map metrics of P: S -> T (elastic-correspondence.txt Sec. 6.1: conformal and
// area distortion, mean-curvature error, flips; reversibility |PQX - X| when Q: T -> S is
// given; geodesic error against `truth` when given), as report.json's metrics.AB / BA.
// vertex_error (optional, with truth): per vertex of S its normalized geodesic error, -1
// where it was not evaluated (report.html colours A by it).
nlohmann::json surface_map_metrics_json(const TriMesh& S, const TriMesh& T, const BarycentricMap& P,
                                        const BarycentricMap* Q, const BarycentricMap* truth,
                                        Eigen::VectorXd* vertex_error = nullptr);

// Adds --elastic-preset, --elastic-eta, --elastic-alpha, --elastic-iterations,
// --elastic-injective, --elastic-partial, --elastic-keep-worse, --truth to the subcommand.
void add_elastic_options(CLI::App* app, ElasticCliOptions& o);

struct ElasticMapArgs {
  std::string A, B, out;
  std::string init = "bim";            // "bim", a map file (A->B) or a folder with map_AB.txt [map_BA.txt]
  std::vector<std::string> landmarks;  // empty or {LA, LB}
  BIMOptions bim;                      // BIM options for the initial maps (landmarks, symmetric overwritten)
};

// Runs the elastic method end to end and writes OUT (map_AB.txt, map_BA.txt, A_on_B.obj,
// B_on_A.obj, report.json, report.html). Throws InputError on bad input.
int run_elastic_surface_map(const ElasticMapArgs& args, const ElasticCliOptions& o,
                            const GlobalOptions& g);

}  // namespace shapemap::cli

// The `--method elastic` branch of `shapemap surface-map` (elastic-correspondence.txt):
// its own options, registered on the surface-map subcommand, and its run function.
// cmd_surface_map.cpp parses A, B, -o, --init, --landmarks and calls run_elastic_surface_map.
#pragma once
#include "common.h"
#include "shapemap/surface/bim.h"
#include <string>
#include <vector>

namespace shapemap::cli {

struct ElasticCliOptions {
  std::string preset = "non-isometric";  // non-isometric (eta 0.1) | near-isometric (0.01) | degenerate (0.002)
  double eta = -1;                       // overrides the preset's bending weight (Eq. 2)
  double alpha = 20;                     // membrane weight (Eq. 2)
  int iterations = 300;                  // K, outer iterations (Algorithm 1)
  bool injective = false;                // E_inj (Eq. 4) instead of E_bij (Eq. 6)
  bool partial = false;                  // Sec. 6.2: no unit-area scaling
  std::string truth_ab;                  // ground truth A->B (map file) for the geodesic error
};

// Adds --elastic-preset, --elastic-eta, --elastic-alpha, --elastic-iterations,
// --elastic-injective, --elastic-partial, --truth to the subcommand.
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

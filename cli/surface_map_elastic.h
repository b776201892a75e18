// The --elastic-* options of `shapemap surface-map` (elastic-correspondence.txt): the
// library's ElasticSettings (shapemap/surface/surface_map_pipeline.h) on the command line.
#pragma once
#include "common.h"
#include "shapemap/maps.h"
#include "shapemap/surface/surface_map_pipeline.h"
#include <string>

namespace shapemap::cli {

// A map file that must map n_source vertices into m_target triangles (exit 2 otherwise).
BarycentricMap read_checked_map(const std::string& path, int n_source, int m_target);

// Adds --elastic-preset, --elastic-eta, --elastic-alpha, --elastic-iterations,
// --elastic-injective, --elastic-partial, --elastic-keep-worse, ... and --truth (into
// truth_ab) to the subcommand.
void add_elastic_options(CLI::App* app, ElasticSettings& o, std::string& truth_ab);

}  // namespace shapemap::cli

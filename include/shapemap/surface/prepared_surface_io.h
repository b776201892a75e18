// A PreparedSurface as bytes, so that BIM's per-surface stage is done once per shape and
// shared by every pair that uses it, also across processes (Python pickling: shapemap batch
// sends it between Dask workers). Every array is stored bit for bit; the point-location
// structures (sphere locator, closest-point tree) are rebuilt from the stored arrays, which
// their builds are deterministic functions of, so a map from a loaded surface is the map
// from the surface it was saved from.
#pragma once
#include "shapemap/surface/surface_map_pipeline.h"
#include <memory>
#include <string>

namespace shapemap {

std::string save_prepared_surface(const PreparedSurface& p);

// Throws Error on bytes that are not a saved PreparedSurface of this format version.
std::shared_ptr<PreparedSurface> load_prepared_surface(const std::string& bytes);

}  // namespace shapemap

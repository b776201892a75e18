// Progress reporting from long computations. The library calls the callback; only
// the CLI draws anything.
#pragma once
#include <functional>
#include <string>

namespace shapemap {

// stage: short name ("bim/candidates"); fraction in [0,1] of that stage.
using ProgressCallback = std::function<void(const std::string& stage, double fraction)>;

inline void report(const ProgressCallback& cb, const std::string& stage, double fraction) {
  if (cb) cb(stage, fraction);
}

}  // namespace shapemap

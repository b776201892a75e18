// Wall-clock timing of stages (reported in result structs and report.json).
#pragma once
#include <chrono>

namespace shapemap {

using Clock = std::chrono::steady_clock;

// Seconds elapsed since t0.
inline double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

}  // namespace shapemap

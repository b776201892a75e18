// splitmix64 (Steele, Lea & Flood 2014): the one integer hash / seed mixer of the library
// (deterministic sampling in BIM, seeds of the shape generator, reproducible jitter).
#pragma once
#include <cstdint>

namespace shapemap {

// The generator's output for state x + golden ratio: a well-mixed hash of x.
inline std::uint64_t splitmix64_hash(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

// Advances the state and returns the next output.
inline std::uint64_t splitmix64(std::uint64_t& state) {
  const std::uint64_t out = splitmix64_hash(state);
  state += 0x9e3779b97f4a7c15ULL;
  return out;
}

}  // namespace shapemap

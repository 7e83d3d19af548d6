#pragma once
/// A 64-bit mix for hashing integers: splitmix64's finaliser (Steele, Lea & Flood, OOPSLA 2014),
/// bijective, every input bit reaching every output bit.
#include <cstdint>

namespace sparkdem {

inline std::uint64_t mix64(std::uint64_t z) {
  z += 0x9E3779B97F4A7C15ULL;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

}  // namespace sparkdem

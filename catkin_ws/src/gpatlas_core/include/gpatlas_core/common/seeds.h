#pragma once

#include <cstdint>

namespace gpatlas_core {

// Mixes two seeds into one (SplitMix64 finaliser) so that nearby seeds give unrelated streams.
std::uint64_t mixSeeds(std::uint64_t a, std::uint64_t b);

}  // namespace gpatlas_core

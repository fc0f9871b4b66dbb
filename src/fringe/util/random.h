// Seeded random numbers. Every randomised algorithm takes a seed in its options and builds its
// own generator from it; the process-wide generator below exists only for tests and examples
// (the test main re-seeds it before every test so each test is reproducible on its own).
#pragma once

#include <cstdint>
#include <random>

namespace fringe::util {

using Rng = std::mt19937_64;

// Process-wide generator for tests; not thread safe.
Rng& GlobalRng();
void SetGlobalSeed(uint64_t seed);

// Derives an independent, well-mixed seed from (seed, stream) so that parallel work items
// (e.g. image rows) get their own generator and results do not depend on the thread count.
uint64_t MixSeed(uint64_t seed, uint64_t stream);

}  // namespace fringe::util

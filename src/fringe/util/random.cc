#include "fringe/util/random.h"

namespace fringe::util {

Rng& GlobalRng() {
  static Rng rng(0x5eed);
  return rng;
}

void SetGlobalSeed(uint64_t seed) { GlobalRng().seed(seed); }

uint64_t MixSeed(uint64_t seed, uint64_t stream) {
  // SplitMix64 finaliser over the combined value: cheap and well distributed.
  uint64_t z = seed + 0x9e3779b97f4a7c15ULL * (stream + 1);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

}  // namespace fringe::util

#include "fringe/util/random.h"

#include <gtest/gtest.h>

#include <set>

namespace fringe::util {
namespace {

TEST(MixSeed, DistinctStreamsGiveDistinctSeeds) {
  std::set<uint64_t> seeds;
  for (uint64_t s = 0; s < 1000; ++s) seeds.insert(MixSeed(42, s));
  EXPECT_EQ(seeds.size(), 1000u);
  EXPECT_EQ(MixSeed(7, 3), MixSeed(7, 3));
  EXPECT_NE(MixSeed(7, 3), MixSeed(8, 3));
}

TEST(GlobalRng, ReseedReproduces) {
  SetGlobalSeed(5);
  const uint64_t a = GlobalRng()();
  SetGlobalSeed(5);
  EXPECT_EQ(GlobalRng()(), a);
}

}  // namespace
}  // namespace fringe::util

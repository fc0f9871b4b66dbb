#include "fringe/io/json.h"

#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "fringe/testing/fringe_test.h"

namespace fringe::io {
namespace {

using nlohmann::json;

using test::ErrorOf;

TEST(ParseJson, BoundsNestingDepthWithoutRecursingIntoTheValue) {
  // 40 000 levels in 80 KB: refused while parsing, naming the source.
  const std::string deep = std::string(40000, '[') + std::string(40000, ']');
  const std::string msg = ErrorOf([&] { ParseJson(deep, "scheme.json"); });
  EXPECT_NE(msg.find("scheme.json: JSON nested deeper than"), std::string::npos) << msg;
  // Ordinary nesting passes.
  EXPECT_EQ(ParseJson("{\"a\": [[1, 2], {\"b\": [3]}]}", "x")["a"][1]["b"][0], 3);
}

TEST(ParseJson, NumberOverflowNamesTheSource) {
  const std::string msg = ErrorOf([] { ParseJson("{\"fx\": 1e999}", "rig.json"); });
  EXPECT_EQ(msg.rfind("rig.json: invalid JSON", 0), 0u) << msg;
}

TEST(ReadJson, RefusesFilesOverTheSizeLimit) {
  test::TempDir dir;
  std::ofstream(dir / "big.json") << "[" << std::string(2000, ' ') << "]";
  const std::string msg = ErrorOf([&] { ReadJson(dir / "big.json", 1000); });
  EXPECT_NE(msg.find("big.json: 2002 bytes, larger than the limit"), std::string::npos) << msg;
}

TEST(CheckKnownKeys, NamesUnknownKeyAndNearestKnownOne) {
  // Issue 10's typo: "radius_mm" on a ring target shortens three keys; all three are named (by
  // edit distance alone dot_radius_mm would be the only suggestion).
  const json j = {{"rows", 7}, {"radius_mm", 5.0}};
  const std::string msg = ErrorOf([&] {
    CheckKnownKeys(j, {"rows", "outer_radius_mm", "inner_radius_mm", "dot_radius_mm"}, "t.json");
  });
  EXPECT_NE(msg.find("t.json: unknown key \"radius_mm\" (did you mean 'outer_radius_mm', "
                     "'inner_radius_mm' or 'dot_radius_mm'?)"),
            std::string::npos)
      << msg;
  const std::string one = ErrorOf([] {
    CheckKnownKeys(json{{"outer_radius", 1}}, {"outer_radius_mm", "inner_radius_mm"}, "t");
  });
  EXPECT_NE(one.find("(did you mean 'outer_radius_mm'?)"), std::string::npos) << one;
  const std::string typo = ErrorOf([] {
    CheckKnownKeys(json{{"spacng_mm", 1}}, {"spacing_mm"}, "t");
  });
  EXPECT_NE(typo.find("did you mean 'spacing_mm'"), std::string::npos) << typo;
  const std::string far = ErrorOf([] { CheckKnownKeys(json{{"zzz", 1}}, {"spacing_mm"}, "t"); });
  EXPECT_EQ(far.find("did you mean"), std::string::npos) << far;
  EXPECT_NO_THROW(CheckKnownKeys(json{{"rows", 1}}, {"rows"}, "t"));
}

TEST(GetNumbers, ExactCountOfFiniteNumbers) {
  const json j = json::parse(R"({"p": [1, 2.5, -3], "short": [1, 2], "text": [1, "2", 3]})");
  EXPECT_EQ(GetNumbers(j, "p", 3, "m"), (std::vector<double>{1, 2.5, -3}));
  EXPECT_NE(
      ErrorOf([&] { GetNumbers(j, "short", 3, "m"); }).find("m.short: expected an array of 3"),
      std::string::npos);
  EXPECT_NE(ErrorOf([&] { GetNumbers(j, "text", 3, "m"); }).find("m.text[1]: expected a number"),
            std::string::npos);
  EXPECT_NE(ErrorOf([&] { GetNumbers(j, "q", 3, "m"); }).find("missing field 'q'"),
            std::string::npos);
}

TEST(GetInteger, RejectsNonIntegersOutOfRangeAndWrongTypes) {
  const json j = json::parse(
      R"({"width": 4294967936, "steps": 4.5, "n": "4", "neg": -3, "ok": 640, "huge": 18446744073709551615})");
  EXPECT_NE(ErrorOf([&] {
              GetInteger(j, "width", 1, 1 << 15, "m.json");
            }).find("m.json.width = 4294967936: must be in [1, 32768]"),
            std::string::npos);
  EXPECT_NE(ErrorOf([&] {
              GetInteger(j, "steps", 3, 64, "m.json");
            }).find("m.json.steps: expected an integer, found a non-integer number 4.5"),
            std::string::npos);
  EXPECT_NE(ErrorOf([&] { GetInteger(j, "n", 3, 64, "m"); }).find("expected an integer"),
            std::string::npos);
  EXPECT_NE(ErrorOf([&] { GetInteger(j, "neg", 0, 64, "m"); }).find("m.neg = -3"),
            std::string::npos);
  EXPECT_NE(ErrorOf([&] { GetInteger(j, "huge", 0, 64, "m"); }).find("must be in"),
            std::string::npos);
  EXPECT_NE(ErrorOf([&] { GetInteger(j, "missing", 0, 64, "m"); }).find("missing field 'missing'"),
            std::string::npos);
  EXPECT_EQ(GetInteger(j, "ok", 1, 1 << 15, "m"), 640);
  EXPECT_EQ(OptionalInteger(j, "absent", 7, 0, 9, "m"), 7);
}

TEST(Brief, BoundsPrintedValues) {
  json deep = 1;
  for (int i = 0; i < 60; ++i) deep = json::array({deep});
  EXPECT_LE(Brief(deep).size(), 63u);
  json wide = json::array();
  for (int i = 0; i < 100000; ++i) wide.push_back(i);
  EXPECT_LE(Brief(wide).size(), 63u);
  EXPECT_EQ(Brief(json("fringe-patterns")), "\"fringe-patterns\"");
}

}  // namespace
}  // namespace fringe::io

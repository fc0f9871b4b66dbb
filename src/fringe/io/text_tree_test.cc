#include "fringe/io/text_tree.h"

#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "fringe/testing/fringe_test.h"
#include "fringe/util/error.h"

namespace fringe::io {
namespace {

namespace fs = std::filesystem;
using test::ErrorOf;

fs::path Write(const test::TempDir& dir, const std::string& name, const std::string& text) {
  const fs::path p = dir / name;
  std::ofstream(p, std::ios::binary) << text;
  return p;
}

TEST(TextTree, YamlAndOpenCvXmlGiveTheSameMatrix) {
  test::TempDir dir;
  const TextTree y = ReadTextTree(Write(dir, "a.yml",
                                        "%YAML:1.0\n---\nK: !!opencv-matrix\n   rows: 2\n   cols: "
                                        "2\n   dt: d\n   data: [ 1., 2.5, -3e2, 4 ]\nname: cam\n"));
  EXPECT_TRUE(y.opencv_header);
  EXPECT_FALSE(y.xml);
  const TextTree x = ReadTextTree(
      Write(dir, "a.xml",
            "<?xml version=\"1.0\"?>\n<opencv_storage>\n<K type_id=\"opencv-matrix\">\n<rows>2</"
            "rows><cols>2</cols><dt>d</dt>\n<data>\n 1. 2.5\n -3e2 4</data></K>\n<name>cam</name>"
            "\n</opencv_storage>\n"));
  EXPECT_TRUE(x.opencv_header);
  EXPECT_TRUE(x.xml);
  for (const TextTree* t : {&y, &x}) {
    const std::optional<TextMatrix> m = ToMatrix(*t->root.Find("K"));
    ASSERT_TRUE(m);
    EXPECT_EQ(m->rows, 2);
    EXPECT_EQ(m->cols, 2);
    EXPECT_EQ(m->data, (std::vector<double>{1, 2.5, -300, 4}));
    EXPECT_EQ(t->root.Find("name")->scalar, "cam");
  }
  EXPECT_EQ(x.root.Find("K")->line, 3);
  // Kalibr's 4x4 as a list of rows; a ragged one is not a matrix.
  const TextTree k =
      ReadTextTree(Write(dir, "k.yaml", "T:\n- [1, 0]\n- [0, 1]\nU: [[1, 2], [3]]\n"));
  EXPECT_EQ(ToMatrix(*k.root.Find("T"))->cols, 2);
  std::string why;
  EXPECT_FALSE(ToMatrix(*k.root.Find("U"), &why));
  EXPECT_EQ(why, "rows of different lengths");
}

TEST(TextTree, MatrixDeclarationsAreCheckedAgainstTheData) {
  test::TempDir dir;
  const TextTree t = ReadTextTree(
      Write(dir, "m.yml",
            "a: {rows: 300000, cols: 3, data: [1]}\nb: {rows: 2, cols: 2, data: [1, 2, 3]}\n"
            "c: {rows: 1, cols: 1, dt: u, data: [1]}\nd: {rows: 1, cols: 2, data: [1, .nan]}\n"));
  std::string why;
  EXPECT_FALSE(ToMatrix(*t.root.Find("a"), &why));
  EXPECT_EQ(why, "rows and cols must be integers in [1, 64]");
  EXPECT_FALSE(ToMatrix(*t.root.Find("b"), &why));
  EXPECT_EQ(why, "data holds 3 numbers, rows x cols = 2 x 2");
  EXPECT_FALSE(ToMatrix(*t.root.Find("c"), &why));
  EXPECT_NE(why.find("element type dt: u"), std::string::npos);
  EXPECT_FALSE(ToMatrix(*t.root.Find("d"), &why));
  EXPECT_EQ(why, "data holds a value that is not a finite number");
}

TEST(TextTree, HostileFilesAreErrorsNamingTheFile) {
  test::TempDir dir;
  const auto error = [&](const std::string& name, const std::string& text) {
    return ErrorOf([&] { ReadTextTree(Write(dir, name, text)); });
  };
  // Depth: flow brackets (refused before yaml-cpp recurses), block mappings, XML elements.
  EXPECT_NE(error("deep.yaml", "a: " + std::string(40000, '[') + std::string(40000, ']'))
                .find("deep.yaml: brackets nested deeper than 32 levels"),
            std::string::npos);
  std::string block;
  for (int i = 0; i < 40; ++i) block += std::string(i, ' ') + "k:\n";
  EXPECT_NE(error("block.yaml", block + std::string(40, ' ') + "v: 1\n").find("block.yaml: line"),
            std::string::npos);
  EXPECT_NE(error(
                "deep.xml", "<r>" + std::string(40 * 3, ' ') +
                                [] {
                                  std::string s;
                                  for (int i = 0; i < 40; ++i) s += "<a>";
                                  s += "1";
                                  for (int i = 0; i < 40; ++i) s += "</a>";
                                  return s;
                                }() +
                                "</r>")
                .find("deep.xml: line 1: nested deeper than 32 levels"),
            std::string::npos);
  // tinyxml2's own depth guard answers first for thousands of levels.
  EXPECT_NE(error("deeper.xml",
                  [] {
                    std::string s;
                    for (int i = 0; i < 5000; ++i) s += "<a>";
                    for (int i = 0; i < 5000; ++i) s += "</a>";
                    return s;
                  }())
                .find("deeper.xml: line 1: not valid XML"),
            std::string::npos);
  // An alias bomb expands in the copy and meets the node limit.
  std::string bomb = "a: &a [1,1,1,1,1,1,1,1,1,1]\n";
  for (char c = 'b'; c <= 'h'; ++c) {
    bomb += std::string(1, c) + ": &" + c + " [";
    for (int i = 0; i < 10; ++i) bomb += std::string(i ? "," : "") + "*" + char(c - 1);
    bomb += "]\n";
  }
  EXPECT_NE(error("bomb.yaml", bomb).find("bomb.yaml: line"), std::string::npos);
  EXPECT_NE(error("bomb.yaml", bomb).find("more than 100000 values"), std::string::npos);
  EXPECT_NE(error("twice.yaml", "a: 1\nb: 2\na: 3\n")
                .find("twice.yaml: line 3: key 'a' appears twice in one mapping"),
            std::string::npos);
  EXPECT_NE(error("twice.xml", "<r><a>1</a><a>2</a></r>")
                .find("twice.xml: line 1: element <a> appears twice in <r>"),
            std::string::npos);
  EXPECT_NE(error("nul.yaml", std::string("a: 1\0", 5)).find("nul.yaml: holds a NUL byte"),
            std::string::npos);
  EXPECT_NE(error("list.yaml", "- 1\n- 2\n").find("list.yaml: the top level is not a mapping"),
            std::string::npos);
  EXPECT_NE(error("bad.yaml", "a: [1, 2\n").find("bad.yaml: line"), std::string::npos);
  EXPECT_NE(error("bad.xml", "<r><a>1</r>").find("bad.xml: line 1: not valid XML"),
            std::string::npos);
  EXPECT_NE(error("long.yaml", "a: " + std::string(5000, 'x') + "\n")
                .find("long.yaml: line 1: a value of 5000 bytes"),
            std::string::npos);
  TextTreeLimits small;
  small.max_bytes = 10;
  EXPECT_NE(ErrorOf([&] {
              ReadTextTree(Write(dir, "big.yaml", "a: 12345678901\n"), small);
            }).find("big.yaml: 15 bytes, more than the 10"),
            std::string::npos);
}

}  // namespace
}  // namespace fringe::io

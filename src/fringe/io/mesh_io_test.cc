#include "fringe/io/mesh_io.h"

#include <gtest/gtest.h>

#include <cstring>
#include <fstream>

#include "fringe/io/ply.h"
#include "fringe/testing/fringe_test.h"
#include "fringe/util/error.h"
#include "fringe/util/files.h"

namespace fringe::io {
namespace {

constexpr double kFloatTolMm = 1e-4;  // positions are stored as float

// An octahedron of radius 50 mm around (100, -20, 300): closed, outward faces.
TriangleMesh Octahedron() {
  TriangleMesh m;
  const Eigen::Vector3d c(100, -20, 300);
  for (int axis = 0; axis < 3; ++axis) {
    for (double s : {50.0, -50.0}) {
      Eigen::Vector3d p = c;
      p[axis] += s;
      m.vertices.push_back(p);
    }
  }
  // vertices: 0 +x, 1 -x, 2 +y, 3 -y, 4 +z, 5 -z
  m.triangles = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                 {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  return m;
}

void ExpectSameGeometry(const TriangleMesh& a, const TriangleMesh& b) {
  ASSERT_EQ(a.NumVertices(), b.NumVertices());
  ASSERT_EQ(a.triangles, b.triangles);
  for (size_t i = 0; i < a.NumVertices(); ++i) {
    EXPECT_LT((a.vertices[i] - b.vertices[i]).norm(), kFloatTolMm) << i;
  }
}

TEST(MeshIo, PlyRoundTripKeepsNormalsAndColours) {
  test::TempDir dir;
  TriangleMesh m = Octahedron();
  m.ComputeVertexNormals();
  for (size_t i = 0; i < m.NumVertices(); ++i) {
    m.colors.push_back({static_cast<uint8_t>(40 * i), 7, 200});
  }
  for (PlyFormat f : {PlyFormat::kBinaryLittleEndian, PlyFormat::kAscii}) {
    WritePly(dir / "m.ply", m, f);
    const TriangleMesh r = ReadMesh(dir / "m.ply");
    ExpectSameGeometry(m, r);
    ASSERT_TRUE(r.has_normals() && r.has_colors());
    for (size_t i = 0; i < m.NumVertices(); ++i) {
      EXPECT_LT((m.normals[i] - r.normals[i]).norm(), 1e-6);
      EXPECT_EQ(m.colors[i], r.colors[i]);
    }
  }
}

TEST(MeshIo, StlBinaryRoundTripWeldsSharedCorners) {
  test::TempDir dir;
  const TriangleMesh m = Octahedron();
  WriteMesh(dir / "m.stl", m, {"test octahedron"});
  // 80-byte header, count, 50 bytes per triangle.
  EXPECT_EQ(std::filesystem::file_size(dir / "m.stl"), 84u + 50u * m.NumTriangles());
  const TriangleMesh r = ReadMesh(dir / "m.stl");
  // Welded: 6 vertices again (in first-use order), the same triangles by position.
  ASSERT_EQ(r.NumVertices(), 6u);
  ASSERT_EQ(r.NumTriangles(), m.NumTriangles());
  for (size_t i = 0; i < m.NumTriangles(); ++i) {
    for (int k = 0; k < 3; ++k) {
      EXPECT_LT((r.vertices[r.triangles[i][k]] - m.vertices[m.triangles[i][k]]).norm(),
                kFloatTolMm);
    }
    EXPECT_LT((r.TriangleNormal(i) - m.TriangleNormal(i)).norm(), 1e-6);
  }
  // The facet normals in the file are the outward triangle normals.
  const std::string data = util::ReadTextFile(dir / "m.stl");
  float n[3];
  std::memcpy(n, data.data() + 84, 12);
  EXPECT_LT((Eigen::Vector3d(n[0], n[1], n[2]) - m.TriangleNormal(0)).norm(), 1e-6);
  EXPECT_NE(data.compare(0, 5, "solid"), 0);
}

TEST(MeshIo, AsciiStlAndObj) {
  test::TempDir dir;
  {
    std::ofstream obj(dir / "t.obj");
    obj << "# quad\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nf 1/1 2/2 3/3 -1/4\n";
    std::ofstream stl(dir / "t.stl");
    stl << "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\n"
           "endloop\nendfacet\nfacet normal 0 0 1\nouter loop\nvertex 1 0 0\nvertex 1 1 0\n"
           "vertex 0 1 0\nendloop\nendfacet\nendsolid t\n";
  }
  const TriangleMesh obj = ReadMesh(dir / "t.obj");
  EXPECT_EQ(obj.NumVertices(), 4u);
  EXPECT_EQ(obj.triangles, (std::vector<TriangleMesh::Triangle>{{0, 1, 2}, {0, 2, 3}}));
  const TriangleMesh stl = ReadMesh(dir / "t.stl");
  EXPECT_EQ(stl.NumVertices(), 4u);  // two corners shared
  EXPECT_EQ(stl.NumTriangles(), 2u);
  // OBJ writing round-trips exactly enough (9 digits) and keeps normals as vn.
  TriangleMesh m = Octahedron();
  m.ComputeVertexNormals();
  WriteMesh(dir / "o.obj", m);
  ExpectSameGeometry(m, ReadMesh(dir / "o.obj"));
}

TEST(MeshIo, BadFilesNameTheFile) {
  test::TempDir dir;
  auto expect_error = [&](const std::string& name, const std::string& content,
                          const std::string& what) {
    {
      std::ofstream f(dir / name, std::ios::binary);
      f << content;
    }
    try {
      ReadMesh(dir / name);
      FAIL() << name << " accepted";
    } catch (const Error& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find(name), std::string::npos) << msg;
      EXPECT_NE(msg.find(what), std::string::npos) << msg;
    }
  };
  expect_error("range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n", "face index 7");
  expect_error("bad.obj", "v 0 0 0\nf 1 x 2\n", "bad face index");
  expect_error("empty.obj", "v 0 0 0\n", "no triangles");
  expect_error("facet.stl", "solid t\nfacet\nouter loop\nvertex 0 0 0\nendloop\nendfacet\n",
               "has 1 vertices");
  // A binary STL whose count claims more triangles than the file holds is neither binary nor
  // ASCII: rejected before anything is allocated.
  std::string truncated(84, '\0');
  const uint32_t count = 1000000;
  std::memcpy(truncated.data() + 80, &count, 4);
  expect_error("cut.stl", truncated + std::string(50, '\0'), "not an STL file");
  expect_error("m.xyz", "0 0 0\n", "unknown mesh extension");
  EXPECT_THROW(ReadMesh(dir / "missing.ply"), Error);
  EXPECT_THROW(WriteMesh(dir / "m.off", Octahedron()), Error);
  TriangleMesh broken = Octahedron();
  broken.triangles.push_back({0, 1, 6});
  EXPECT_THROW(WriteMesh(dir / "broken.stl", broken), Error);
  EXPECT_FALSE(std::filesystem::exists(dir / "broken.stl"));
}

}  // namespace
}  // namespace fringe::io

#include "fskin/io/mesh_io.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <limits>

#include "fskin/core/error.h"
#include "fskin/util/atomic_file.h"
#include "test_util.h"

namespace fskin::io {
namespace {

using fskin::testing::directory_listing;
using fskin::testing::expect_error;
using fskin::testing::temp_dir;

// Test files live in a fresh directory per test.
class MeshFiles : public ::testing::Test {
 protected:
  std::string file(const std::string& name) const { return (dir_ / name).string(); }
  static std::string test_name() {
    std::string name = ::testing::UnitTest::GetInstance()->current_test_info()->name();
    std::replace(name.begin(), name.end(), '/', '_');  // parameterised: "Name/0"
    return "mesh_" + name;
  }
  const std::filesystem::path dir_ = temp_dir(test_name());
};

// A unit square (two triangles) plus a lifted apex, with colours.
Mesh small_mesh(bool with_colors) {
  Mesh mesh;
  mesh.vertices = torch::tensor({{0.f, 0.f, 0.f}, {1.f, 0.f, 0.f}, {1.f, 1.f, 0.f},
                                 {0.f, 1.f, 0.f}, {0.5f, 0.5f, 0.123456789f}});
  mesh.faces = torch::tensor({{0, 1, 2}, {0, 2, 3}, {0, 1, 4}}, torch::kInt64);
  if (with_colors) {
    mesh.colors = torch::tensor({{255, 0, 0}, {0, 255, 0}, {0, 0, 255}, {10, 20, 30}, {1, 2, 3}},
                                torch::kUInt8);
  }
  return mesh;
}

void expect_same_mesh(const Mesh& actual, const Mesh& expected) {
  EXPECT_TRUE(torch::equal(actual.vertices, expected.vertices)) << actual.vertices;
  EXPECT_TRUE(torch::equal(actual.faces, expected.faces)) << actual.faces;
  ASSERT_EQ(actual.colors.defined(), expected.colors.defined());
  if (expected.colors.defined()) {
    EXPECT_TRUE(torch::equal(actual.colors, expected.colors)) << actual.colors;
  }
}

// Appends `value` to `out` as binary in the given byte order.
template <typename T>
void put(std::string& out, T value, bool big_endian) {
  char raw[sizeof(T)];
  std::memcpy(raw, &value, sizeof(T));
  if (big_endian) std::reverse(raw, raw + sizeof(T));
  out.append(raw, sizeof(T));
}

// A binary PLY of a quad with colours, unknown properties (a double 'confidence' per
// vertex, a list on faces), ushort indices with uint counts and an unknown element.
std::string binary_quad_ply(bool big_endian) {
  std::string out = std::string("ply\nformat ") +
                    (big_endian ? "binary_big_endian" : "binary_little_endian") +
                    " 1.0\ncomment test\n"
                    "element vertex 4\nproperty double x\nproperty double y\nproperty double z\n"
                    "property double confidence\n"
                    "property uchar red\nproperty uchar green\nproperty uchar blue\n"
                    "element face 1\nproperty list uchar float texcoord\n"
                    "property list uint ushort vertex_index\nproperty int flags\n"
                    "element material 1\nproperty list uchar char name\nend_header\n";
  const double xyz[4][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0.25}};
  for (int i = 0; i < 4; ++i) {
    for (double c : xyz[i]) put(out, c, big_endian);
    put(out, 0.5, big_endian);
    for (uint8_t c : {uint8_t(i * 10), uint8_t(i * 20), uint8_t(i * 30)}) put(out, c, big_endian);
  }
  put(out, uint8_t{2}, big_endian);
  put(out, 0.25f, big_endian);
  put(out, 0.75f, big_endian);
  put(out, uint32_t{4}, big_endian);
  for (uint16_t index : {0, 1, 2, 3}) put(out, index, big_endian);
  put(out, int32_t{-1}, big_endian);
  put(out, uint8_t{3}, big_endian);
  out += "abc";
  return out;
}

Mesh expected_quad() {
  Mesh mesh;
  mesh.vertices = torch::tensor({{0.f, 0.f, 0.f}, {1.f, 0.f, 0.f}, {1.f, 1.f, 0.f}, {0.f, 1.f, 0.25f}});
  mesh.faces = torch::tensor({{0, 1, 2}, {0, 2, 3}}, torch::kInt64);  // fan from vertex 0
  mesh.colors =
      torch::tensor({{0, 0, 0}, {10, 20, 30}, {20, 40, 60}, {30, 60, 90}}, torch::kUInt8);
  return mesh;
}

TEST_F(MeshFiles, PlyReadsBinaryInBothByteOrdersSkippingUnknownProperties) {
  for (bool big_endian : {false, true}) {
    SCOPED_TRACE(big_endian ? "big endian" : "little endian");
    write_file_atomically(file("q.ply"), binary_quad_ply(big_endian));
    expect_same_mesh(read_ply(file("q.ply")), expected_quad());
  }
}

TEST_F(MeshFiles, PlyReadsAsciiWithColoursPolygonsAndUnknownElements) {
  write_file_atomically(file("a.ply"),
                        "ply\r\nformat ascii 1.0\r\ncomment made by hand\r\n"
                        "element vertex 5\r\nproperty float x\r\nproperty float y\r\n"
                        "property float z\r\nproperty float nx\r\n"
                        "property uchar red\r\nproperty uchar green\r\nproperty uchar blue\r\n"
                        "element edge 1\r\nproperty int vertex1\r\nproperty int vertex2\r\n"
                        "element face 2\r\nproperty list uchar int vertex_indices\r\n"
                        "end_header\r\n"
                        "0 0 0 1 255 0 0\r\n1 0 0 1 0 255 0\r\n1 1 0 1 0 0 255\r\n"
                        "0 1 0 1 1 2 3\r\n0.5 0.5 -2.5e-1 1 4 5 6\r\n"
                        "0 1\r\n"
                        "3 0 1 2\r\n5 0 1 2 3 4\r\n");
  const Mesh mesh = read_ply(file("a.ply"));
  EXPECT_TRUE(torch::equal(mesh.faces, torch::tensor({{0, 1, 2}, {0, 1, 2}, {0, 2, 3}, {0, 3, 4}},
                                                     torch::kInt64)))
      << mesh.faces;
  EXPECT_FLOAT_EQ(mesh.vertices[4][2].item<float>(), -0.25f);
  ASSERT_TRUE(mesh.colors.defined());
  EXPECT_EQ(mesh.colors[3][2].item<uint8_t>(), 3);
}

TEST_F(MeshFiles, PlyRejectsFaceIndexOutOfRange) {
  write_file_atomically(file("bad.ply"),
                        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                        "property float y\nproperty float z\nelement face 1\n"
                        "property list uchar int vertex_indices\nend_header\n"
                        "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n");
  expect_error([&] { read_ply(file("bad.ply")); }, {"bad.ply", "out of range"});
}

TEST_F(MeshFiles, PlyRejectsNonFiniteCoordinates) {
  std::string ply = binary_quad_ply(false);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::memcpy(&ply[ply.find("end_header\n") + 11 + 8], &nan, sizeof(double));  // vertex 0, y
  write_file_atomically(file("nan.ply"), ply);
  expect_error([&] { read_ply(file("nan.ply")); }, {"nan.ply", "non-finite"});
}

TEST_F(MeshFiles, PlyRejectsTruncatedDataAndBadHeaders) {
  const std::string ply = binary_quad_ply(false);
  write_file_atomically(file("cut.ply"), ply.substr(0, ply.size() - 10));
  expect_error([&] { read_ply(file("cut.ply")); }, {"cut.ply", "truncated", "element 'face'"});

  write_file_atomically(file("short.ply"),
                        "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\n"
                        "property float y\nproperty float z\nend_header\n0 0 0\n1 1\n");
  expect_error([&] { read_ply(file("short.ply")); }, {"short.ply", "truncated"});

  const std::pair<std::string, std::string> bad_headers[] = {
      {"ply\nformat binary_middle_endian 1.0\nend_header\n", "unknown format"},
      {"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n", "no 'end_header'"},
      {"ply\nformat ascii 1.0\nelement vertex 1\nproperty quaternion x\nend_header\n",
       "unknown property type"},
      {"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n1\n",
       "no 'y' property"},
      {"ply\nelement vertex 0\nend_header\n", "no 'format'"},
      {"solid stl\n", "not a PLY file"}};
  for (const auto& [header, problem] : bad_headers) {
    write_file_atomically(file("h.ply"), header);
    expect_error([&] { read_ply(file("h.ply")); }, {"h.ply", problem});
  }
}

class MeshRoundTrip : public MeshFiles, public ::testing::WithParamInterface<const char*> {};

TEST_P(MeshRoundTrip, ExactWithAndWithoutColours) {
  for (bool with_colors : {true, false}) {
    SCOPED_TRACE(with_colors ? "colours" : "no colours");
    const Mesh mesh = small_mesh(with_colors);
    write_mesh(file(GetParam()), mesh);
    expect_same_mesh(read_mesh(file(GetParam())), mesh);
  }
  EXPECT_EQ(directory_listing(dir_), std::vector<std::string>{GetParam()});  // no temporaries
}

INSTANTIATE_TEST_SUITE_P(PlyAndObj, MeshRoundTrip, ::testing::Values("m.ply", "m.obj", "m.PLY"));

TEST_F(MeshFiles, ObjTriangulatesPolygonsAndResolvesRelativeIndices) {
  write_file_atomically(file("q.obj"),
                        "# quad and pentagon\nmtllib missing.mtl\n"
                        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 2 0 # top\n"
                        "vn 0 0 1\n"
                        "f 1//1 2//1 3//1 4//1\nf -5 -4 -3 -2 -1\n");
  const Mesh mesh = read_obj(file("q.obj"));
  EXPECT_EQ(mesh.num_vertices(), 5);
  EXPECT_FALSE(mesh.colors.defined());
  EXPECT_TRUE(torch::equal(mesh.faces, torch::tensor({{0, 1, 2}, {0, 2, 3}, {0, 1, 2}, {0, 2, 3},
                                                      {0, 3, 4}},
                                                     torch::kInt64)))
      << mesh.faces;
}

TEST_F(MeshFiles, ObjRejectsOutOfRangeIndicesAndNonFiniteCoordinates) {
  for (const char* faces : {"f 1 2 3 4\n", "f 1 2 9\n", "f -9 1 2\n"}) {
    write_file_atomically(file("range.obj"), std::string("v 0 0 0\nv 1 0 0\nv 0 1 0\n") + faces);
    expect_error([&] { read_obj(file("range.obj")); }, {"range.obj", "out of range"});
  }
  write_file_atomically(file("nan.obj"), "v 0 NaN 0\nv 1 0 0\nv 0 1 -inf\nf 1 2 3\n");
  expect_error([&] { read_obj(file("nan.obj")); }, {"nan.obj", "line 1", "non-finite"});
}

TEST_F(MeshFiles, UnsupportedFormatAndMissingFilesNameTheFile) {
  expect_error([&] { write_mesh(file("m.stl"), small_mesh(false)); },
               {"m.stl", "unsupported mesh format '.stl'"});
  expect_error([&] { read_mesh(file("m.stl")); }, {"m.stl", "unsupported mesh format"});
  for (const char* name : {"none.ply", "none.obj"}) {
    expect_error([&] { read_mesh(file(name)); }, {name, "no such file"});
  }
}

TEST_F(MeshFiles, WritersRejectInvalidMeshes) {
  Mesh mesh = small_mesh(false);
  mesh.faces[0][0] = 7;
  expect_error([&] { write_ply(file("x.ply"), mesh); }, {"x.ply", "out of range"});
  expect_error([&] { write_obj(file("x.obj"), mesh); }, {"x.obj", "out of range"});
  EXPECT_TRUE(directory_listing(dir_).empty());
}

}  // namespace
}  // namespace fskin::io

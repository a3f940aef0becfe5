#include "fskin/io/mesh_io.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "fskin/util/atomic_file.h"
#include "test_util.h"

namespace fskin::io {
namespace {

using fskin::testing::expect_error;
using fskin::testing::temp_dir;

Mesh tetrahedron(bool colors) {
  Mesh m;
  m.vertices = torch::tensor({0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f}).reshape({4, 3});
  m.faces = torch::tensor({0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3}, torch::kInt64).reshape({4, 3});
  if (colors) m.colors = torch::tensor({255, 0, 0, 0, 255, 0, 0, 0, 255, 10, 20, 30}, torch::kUInt8).reshape({4, 3});
  return m;
}

class MeshRoundTrip : public ::testing::TestWithParam<std::string> {};

TEST_P(MeshRoundTrip, VerticesFacesColours) {
  const auto path = (temp_dir("mesh_rt") / ("t" + GetParam())).string();
  const auto m = tetrahedron(true);
  write_mesh(path, m);
  const auto back = read_mesh(path);
  EXPECT_TRUE(torch::allclose(back.vertices, m.vertices));
  EXPECT_TRUE(torch::equal(back.faces, m.faces));
  ASSERT_TRUE(back.colors.defined());
  EXPECT_TRUE(torch::equal(back.colors, m.colors));
}
INSTANTIATE_TEST_SUITE_P(PlyAndObj, MeshRoundTrip, ::testing::Values(".ply", ".obj"));

TEST(PlyRead, AsciiWithQuadsAndExtraProperties) {
  const auto path = (temp_dir("ply_ascii") / "q.ply").string();
  write_file_atomically(path,
                        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\n"
                        "property float y\nproperty float z\nproperty float nx\n"
                        "element face 1\nproperty list uchar int vertex_indices\n"
                        "element edge 1\nproperty int a\nproperty int b\nend_header\n"
                        "0 0 0 9\n1 0 0 9\n1 1 0 9\n0 1 0 9\n4 0 1 2 3\n0 1\n");
  const auto m = read_ply(path);
  EXPECT_EQ(m.num_vertices(), 4);
  ASSERT_EQ(m.num_faces(), 2);  // quad fan-triangulated
  EXPECT_TRUE(torch::equal(m.faces, torch::tensor({0, 1, 2, 0, 2, 3}, torch::kInt64).reshape({2, 3})));
  EXPECT_FALSE(m.colors.defined());
}

TEST(PlyRead, BigEndianBinary) {
  std::string body;
  auto put_float = [&](float f) {
    unsigned char b[4];
    std::memcpy(b, &f, 4);
    body.append({static_cast<char>(b[3]), static_cast<char>(b[2]), static_cast<char>(b[1]), static_cast<char>(b[0])});
  };
  for (float f : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f}) put_float(f);
  body += std::string("\x03\x00\x00\x00\x00\x00\x00\x00\x01\x00\x00\x00\x02", 13);
  const auto path = (temp_dir("ply_be") / "be.ply").string();
  write_file_atomically(path, "ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty float x\n"
                              "property float y\nproperty float z\nelement face 1\n"
                              "property list uchar int vertex_indices\nend_header\n" + body);
  const auto m = read_ply(path);
  EXPECT_FLOAT_EQ(m.vertices[1][0].item<float>(), 1.0f);
  EXPECT_TRUE(torch::equal(m.faces[0], torch::tensor({0, 1, 2}, torch::kInt64)));
}

TEST(PlyRead, BadInputNamesFileAndProblem) {
  const auto dir = temp_dir("ply_bad");
  const std::string header = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                             "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
  write_file_atomically((dir / "range.ply").string(), header + "0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n");
  expect_error([&] { read_ply((dir / "range.ply").string()); }, {"range.ply", "out of range"});
  write_file_atomically((dir / "nan.ply").string(), header + "0 0 0\nnan 0 0\n0 1 0\n3 0 1 2\n");
  expect_error([&] { read_ply((dir / "nan.ply").string()); }, {"nan.ply", "non-finite"});
  write_file_atomically((dir / "short.ply").string(), header + "0 0 0\n1 0 0\n");
  expect_error([&] { read_ply((dir / "short.ply").string()); }, {"short.ply", "truncated"});
  write_file_atomically((dir / "magic.ply").string(), "solid stl\n");
  expect_error([&] { read_ply((dir / "magic.ply").string()); }, {"magic.ply", "not a PLY"});
  expect_error([&] { read_mesh((dir / "missing.ply").string()); }, {"missing.ply", "no such file"});
  expect_error([&] { read_mesh((dir / "x.stl").string()); }, {"x.stl", "unsupported"});
}

TEST(PlyRead, TruncatedBinaryBody) {
  const auto dir = temp_dir("ply_trunc");
  const auto path = (dir / "t.ply").string();
  write_ply(path, tetrahedron(false));
  const auto bytes = read_file(path);
  write_file_atomically(path, bytes.substr(0, bytes.size() - 7));
  expect_error([&] { read_ply(path); }, {"t.ply", "truncated"});
}

TEST(ObjRead, QuadsAreTriangulatedAndBadIndexRejected) {
  const auto dir = temp_dir("obj");
  write_file_atomically((dir / "q.obj").string(), "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n");
  const auto m = read_obj((dir / "q.obj").string());
  EXPECT_EQ(m.num_faces(), 2);
  write_file_atomically((dir / "bad.obj").string(), "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 9\n");
  EXPECT_THROW(read_obj((dir / "bad.obj").string()), std::runtime_error);
}

}  // namespace
}  // namespace fskin::io

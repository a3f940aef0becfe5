#include "fskin/io/npz.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <filesystem>

#include "fskin/util/atomic_file.h"
#include "test_util.h"

namespace fskin::io {
namespace {

namespace fs = std::filesystem;
using fskin::testing::expect_error;
using fskin::testing::temp_dir;

std::map<std::string, torch::Tensor> every_dtype() {
  torch::manual_seed(0);
  return {
      {"f32", torch::randn({3, 4})},
      {"f64", torch::randn({2, 3, 2}, torch::kFloat64)},
      {"i8", torch::randint(-100, 100, {5}, torch::kInt8)},
      {"i16", torch::randint(-1000, 1000, {2, 2}, torch::kInt16)},
      {"i32", torch::randint(-100000, 100000, {7, 1}, torch::kInt32)},
      {"i64", torch::randint(-100000, 100000, {4, 3}, torch::kInt64)},
      {"u8", torch::randint(0, 255, {6}, torch::kUInt8)},
      {"b1", torch::randint(0, 2, {3, 3}, torch::kInt64).to(torch::kBool)},
      {"scalar", torch::tensor(3.5)},
      {"empty", torch::zeros({0, 3})},
  };
}

class NpzRoundTrip : public ::testing::TestWithParam<bool> {};

TEST_P(NpzRoundTrip, EveryDtypeAndStrings) {
  const auto dir = temp_dir("npz_roundtrip");
  const auto path = (dir / "a.npz").string();
  NpzWriter writer;
  for (const auto& [key, t] : every_dtype()) writer.add(key, t);
  writer.add_strings("names", {"pelvis", "left_hip", "ü-ß", ""});
  writer.save(path, /*compress=*/GetParam());

  NpzReader reader(path);
  EXPECT_EQ(reader.keys().size(), every_dtype().size() + 1);
  for (const auto& [key, t] : every_dtype()) {
    const auto back = reader.tensor(key);
    EXPECT_EQ(back.scalar_type(), t.scalar_type()) << key;
    EXPECT_EQ(back.sizes(), t.sizes()) << key;
    EXPECT_TRUE(torch::equal(back, t)) << key;
  }
  EXPECT_EQ(reader.strings("names"), (std::vector<std::string>{"pelvis", "left_hip", "ü-ß", ""}));
  for (const auto& entry : fs::directory_iterator(dir))
    EXPECT_EQ(entry.path().filename().string().find(".tmp-"), std::string::npos);
}
INSTANTIATE_TEST_SUITE_P(StoredAndCompressed, NpzRoundTrip, ::testing::Values(false, true));

TEST(Npz, SavingTwiceGivesIdenticalBytes) {
  const auto dir = temp_dir("npz_determinism");
  NpzWriter writer;
  for (const auto& [key, t] : every_dtype()) writer.add(key, t);
  writer.save((dir / "a.npz").string());
  writer.save((dir / "b.npz").string());
  EXPECT_EQ(read_file((dir / "a.npz").string()), read_file((dir / "b.npz").string()));
}

TEST(Npz, MissingFileAndMissingKeyNameTheProblem) {
  expect_error([] { NpzReader("/nonexistent/model.npz"); }, {"/nonexistent/model.npz", "no such file"});
  const auto dir = temp_dir("npz_missing_key");
  NpzWriter writer;
  writer.add("v_template", torch::zeros({2, 3}));
  writer.save((dir / "m.npz").string());
  NpzReader reader((dir / "m.npz").string());
  expect_error([&] { reader.tensor("weights"); }, {"m.npz", "'weights'", "v_template"});
}

TEST(Npz, NotAZipFile) {
  const auto dir = temp_dir("npz_notzip");
  write_file_atomically((dir / "x.npz").string(), "this is not a zip archive at all");
  expect_error([&] { NpzReader((dir / "x.npz").string()); }, {"x.npz", "zip"});
}

TEST(Npz, TruncatedArchiveIsDetected) {
  const auto dir = temp_dir("npz_truncated");
  const auto path = (dir / "t.npz").string();
  NpzWriter writer;
  writer.add("big", torch::randn({200, 50}));
  writer.save(path, /*compress=*/false);
  const auto bytes = read_file(path);
  write_file_atomically(path, bytes.substr(0, bytes.size() / 2));
  EXPECT_THROW(
      {
        NpzReader reader(path);
        reader.tensor("big");
      },
      std::runtime_error);
}

// .npy payloads exactly as numpy writes them (header text from numpy 1.24).
std::string npy(const std::string& dict, const std::string& data) {
  std::string header = dict;
  const size_t unpadded = 10 + header.size() + 1;
  header.append((64 - unpadded % 64) % 64, ' ');
  header += '\n';
  std::string out("\x93NUMPY\x01\x00", 8);
  out.push_back(static_cast<char>(header.size() & 0xff));
  out.push_back(static_cast<char>(header.size() >> 8));
  return out + header + data;
}

TEST(Npy, FortranOrderIsTransposedIntoCOrder) {
  // np.asfortranarray([[1, 2, 3], [4, 5, 6]], dtype='<f8'): memory 1 4 2 5 3 6.
  const double mem[] = {1, 4, 2, 5, 3, 6};
  const auto t = decode_npy(
      npy("{'descr': '<f8', 'fortran_order': True, 'shape': (2, 3), }",
          std::string(reinterpret_cast<const char*>(mem), sizeof(mem))),
      "fortran");
  EXPECT_TRUE(torch::equal(t, torch::tensor({1.0, 2.0, 3.0, 4.0, 5.0, 6.0}, torch::kFloat64).reshape({2, 3})));
}

TEST(Npy, Uint32IsWidenedToInt64) {
  const uint32_t mem[] = {4294967295u, 0, 1};
  const auto t = decode_npy(npy("{'descr': '<u4', 'fortran_order': False, 'shape': (3,), }",
                                std::string(reinterpret_cast<const char*>(mem), sizeof(mem))),
                            "kintree");
  EXPECT_EQ(t.scalar_type(), torch::kInt64);
  EXPECT_EQ(t[0].item<int64_t>(), 4294967295LL);
}

TEST(Npy, UnsupportedDtypesNameTheDtype) {
  expect_error([] { decode_npy(npy("{'descr': '|O', 'fortran_order': False, 'shape': (2,), }", "xxxxxxxxxxxxxxxx"), "obj.npy"); },
               {"obj.npy", "object"});
  expect_error([] { decode_npy(npy("{'descr': '>f4', 'fortran_order': False, 'shape': (1,), }", "xxxx"), "be.npy"); },
               {"be.npy", "big-endian"});
  expect_error([] { decode_npy(npy("{'descr': '<c8', 'fortran_order': False, 'shape': (1,), }", "xxxxxxxx"), "c.npy"); },
               {"c.npy", "'<c8'"});
}

TEST(Npy, TruncatedDataAndBadMagic) {
  expect_error([] { decode_npy(npy("{'descr': '<f4', 'fortran_order': False, 'shape': (10,), }", "abcd"), "short.npy"); },
               {"short.npy", "truncated"});
  expect_error([] { decode_npy("garbage", "g.npy"); }, {"g.npy", "magic"});
}

TEST(Npy, WriteAndReadFile) {
  const auto dir = temp_dir("npy_file");
  const auto t = torch::arange(12, torch::kInt32).reshape({3, 4});
  write_npy((dir / "a.npy").string(), t);
  EXPECT_TRUE(torch::equal(read_npy((dir / "a.npy").string()), t));
}

}  // namespace
}  // namespace fskin::io

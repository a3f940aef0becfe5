#include "fskin/io/npz.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <atomic>
#include <cstdlib>
#include <ctime>
#include <filesystem>

#include "fskin/core/error.h"
#include "fskin/util/atomic_file.h"
#include "test_util.h"

namespace fskin::io {
namespace {

namespace fs = std::filesystem;
using fskin::testing::directory_listing;
using fskin::testing::expect_error;
using fskin::testing::temp_dir;

// Fixtures written by tests/data/make_npz_fixtures.py in numpy's exact byte layout.
std::string fixture(const std::string& name) {
  return std::string(FSKIN_TEST_DATA_DIR) + "/" + name;
}

const std::vector<std::string> kNames = {"pelvis", "left_hip", "caf\u00e9", "\U0001F600"};

// One tensor of every supported dtype, plus shapes numpy handles specially. The values
// of the first entries match the fixtures.
std::map<std::string, torch::Tensor> every_dtype() {
  return {
      {"f4", torch::tensor({{0.5f, -1.25f, 2.f}, {3.f, 4.f, 1e-3f}})},
      {"f8", torch::tensor({1.0 / 3, -2.0, 1e300}, torch::kFloat64)},
      {"i1", torch::tensor({-128, 0, 127}, torch::kInt8)},
      {"i2", torch::tensor({-32768, 1, 32767}, torch::kInt16)},
      {"i4", torch::tensor({-1, 0, 2147483647}, torch::kInt32)},
      {"i8", torch::tensor({-(int64_t{1} << 40), int64_t{1} << 62}, torch::kInt64)},
      {"u1", torch::tensor({0, 255}, torch::kUInt8)},
      {"b1", torch::tensor({true, false, true})},
      {"scalar", torch::tensor(2.5, torch::kFloat64)},
      {"empty", torch::zeros({0, 3})},
      {"cube", torch::arange(24, torch::kFloat32).reshape({2, 3, 4})},
  };
}

void expect_same(const torch::Tensor& actual, const torch::Tensor& expected,
                 const std::string& key) {
  SCOPED_TRACE(key);
  EXPECT_EQ(actual.scalar_type(), expected.scalar_type());
  EXPECT_EQ(actual.sizes(), expected.sizes());
  EXPECT_TRUE(torch::equal(actual, expected)) << actual;
}

// A .npy payload with a hand-written header dict (numpy's padding).
std::string npy(const std::string& dict, const std::string& data) {
  std::string header = dict;
  header.append((64 - (10 + header.size() + 1) % 64) % 64, ' ');
  header += '\n';
  std::string out("\x93NUMPY\x01\x00", 8);
  out.push_back(static_cast<char>(header.size() & 0xff));
  out.push_back(static_cast<char>(header.size() >> 8));
  return out + header + data;
}

class NpzRoundTrip : public ::testing::TestWithParam<bool> {};

TEST_P(NpzRoundTrip, EveryDtypeAndStringsWithoutTemporaries) {
  const auto dir = temp_dir(std::string("npz_roundtrip_") + (GetParam() ? "z" : "s"));
  const auto arrays = every_dtype();
  NpzWriter writer;
  for (const auto& [key, tensor] : arrays) writer.add(key, tensor);
  writer.add_strings("names", kNames);
  writer.add_strings("no_names", {});
  writer.save((dir / "a.npz").string(), /*compress=*/GetParam());

  NpzReader reader((dir / "a.npz").string());
  std::vector<std::string> expected_keys{"names", "no_names"};
  for (const auto& entry : arrays) expected_keys.push_back(entry.first);
  std::sort(expected_keys.begin(), expected_keys.end());
  EXPECT_EQ(reader.keys(), expected_keys);
  for (const auto& [key, tensor] : arrays) expect_same(reader.tensor(key), tensor, key);
  EXPECT_EQ(reader.strings("names"), kNames);
  EXPECT_TRUE(reader.strings("no_names").empty());
  EXPECT_TRUE(reader.contains("f4"));
  EXPECT_FALSE(reader.contains("f5"));
  EXPECT_EQ(directory_listing(dir), std::vector<std::string>{"a.npz"});
}

INSTANTIATE_TEST_SUITE_P(StoredAndCompressed, NpzRoundTrip, ::testing::Bool());

TEST(NpzWriter, SavingTwiceGivesIdenticalBytes) {
  const auto dir = temp_dir("npz_determinism");
  for (bool compress : {false, true}) {
    NpzWriter writer;
    writer.add("b", torch::arange(100, torch::kFloat32));
    writer.add("a", torch::eye(3, torch::kFloat64));
    writer.add_strings("names", kNames);
    writer.save((dir / "first.npz").string(), compress);
    writer.save((dir / "second.npz").string(), compress);
    EXPECT_EQ(read_file((dir / "first.npz").string()), read_file((dir / "second.npz").string()));
    EXPECT_EQ(NpzReader((dir / "first.npz").string()).keys(),
              (std::vector<std::string>{"a", "b", "names"}));
  }
}

TEST(NpzWriter, BytesDoNotDependOnTheTimeZone) {
  const auto dir = temp_dir("npz_time_zone");
  NpzWriter writer;
  writer.add("a", torch::arange(10));
  const char* old_tz = std::getenv("TZ");
  const std::string saved = old_tz ? old_tz : "";
  for (const auto& [zone, name] : {std::pair{"UTC", "utc.npz"}, {"Asia/Tokyo", "tokyo.npz"}}) {
    ::setenv("TZ", zone, 1);
    ::tzset();
    writer.save((dir / name).string());
  }
  old_tz ? ::setenv("TZ", saved.c_str(), 1) : ::unsetenv("TZ");
  ::tzset();
  EXPECT_EQ(read_file((dir / "utc.npz").string()), read_file((dir / "tokyo.npz").string()));
}

TEST(NpzWriter, RejectsDuplicateEmptyAndUnsupported) {
  NpzWriter writer;
  writer.add("a", torch::ones(1));
  expect_error([&] { writer.add("a", torch::ones(1)); }, {"'a' added twice"});
  expect_error([&] { writer.add_strings("", {"x"}); }, {"empty key"});
  expect_error([&] { writer.add("half", torch::ones(2, torch::kFloat16)); }, {"'half'", "Half"});
  expect_error([&] { writer.add_strings("bad", {"\xff"}); }, {"'bad'", "UTF-8"});
}

class NumpyFixture : public ::testing::TestWithParam<std::string> {};

TEST_P(NumpyFixture, ReadsEveryArrayAsNumpyWroteIt) {
  NpzReader reader(fixture(GetParam()));
  EXPECT_EQ(reader.keys().size(), 13u);
  const auto arrays = every_dtype();
  for (const char* key : {"f4", "i1", "i2", "i8", "u1", "b1", "scalar", "empty"}) {
    expect_same(reader.tensor(key), arrays.at(key), key);
  }
  expect_same(reader.tensor("f8"),
              torch::tensor({{1.0 / 3, -2.0}, {1e300, 0.0}}, torch::kFloat64), "f8");
  expect_same(reader.tensor("i4"), torch::tensor({-1, 0, 1, 2147483647}, torch::kInt32), "i4");
  // SMPL's uint32 kintree_table widens to int64 without sign extension.
  expect_same(reader.tensor("kintree_table"),
              torch::tensor(std::vector<int64_t>{4294967295, 0, 1, 0, 1, 2}).reshape({2, 3}),
              "kintree");
  // Fortran order comes back in C order with the same logical values.
  const torch::Tensor fortran = reader.tensor("fortran");
  expect_same(fortran, torch::arange(6, torch::kFloat32).reshape({2, 3}), "fortran");
  EXPECT_TRUE(fortran.is_contiguous());
  EXPECT_EQ(reader.strings("names"), kNames);
}

INSTANTIATE_TEST_SUITE_P(SavezAndSavezCompressed, NumpyFixture,
                         ::testing::Values("numpy_savez.npz", "numpy_savez_compressed.npz"));

TEST(Npy, EncodeMatchesNumpyBytesAndNonContiguousIsCOrder) {
  EXPECT_EQ(encode_npy(every_dtype().at("f4")), read_file(fixture("numpy_save_f4.npy")));
  const torch::Tensor transposed = every_dtype().at("f4").t();  // not contiguous
  expect_same(decode_npy(encode_npy(transposed), "t"), transposed.contiguous(), "transposed");
}

TEST(Npy, ReadsHeaderVersions2And3) {
  const torch::Tensor expected = torch::tensor({7, -7}, torch::kInt64);
  expect_same(read_npy(fixture("numpy_v2.npy")), expected, "v2");
  expect_same(read_npy(fixture("numpy_v3.npy")), expected, "v3");
}

TEST(Npy, WriteAndReadFile) {
  const auto dir = temp_dir("npy_file");
  const auto t = torch::arange(12, torch::kInt32).reshape({3, 4});
  write_npy((dir / "a.npy").string(), t);
  expect_same(read_npy((dir / "a.npy").string()), t, "a");
}

TEST(Npy, UnsupportedDtypesNameFileAndDtype) {
  expect_error([] { read_npy(fixture("numpy_object.npy")); },
               {"numpy_object.npy", "'|O'", "pickled"});
  expect_error([] { read_npy(fixture("numpy_big_endian.npy")); },
               {"numpy_big_endian.npy", "'>f4'", "big-endian"});
  expect_error(
      [] {
        decode_npy(npy("{'descr': '<c8', 'fortran_order': False, 'shape': (1,), }", "12345678"),
                   "c.npy");
      },
      {"c.npy", "'<c8'"});
  expect_error(
      [] {
        decode_npy(npy("{'descr': [('a', '<f4')], 'fortran_order': False, 'shape': (1,), }",
                       "1234"),
                   "rec.npy");
      },
      {"rec.npy", "[('a', '<f4')]"});
}

TEST(Npy, RejectsTruncatedOversizedAndMalformedData) {
  const std::string bytes = encode_npy(torch::ones({3, 4}));
  expect_error([&] { decode_npy(bytes.substr(0, bytes.size() - 1), "x.npy"); },
               {"x.npy", "truncated"});
  expect_error([&] { decode_npy(bytes.substr(0, 40), "x.npy"); },
               {"x.npy", "truncated .npy header"});
  expect_error([&] { decode_npy(bytes + "abcd", "x.npy"); }, {"x.npy", "data size mismatch"});
  expect_error([] { decode_npy("garbage", "g.npy"); }, {"g.npy", "magic"});
  std::string bad_shape = bytes;
  bad_shape.replace(bad_shape.find("(3, 4)"), 6, "(3, x)");
  expect_error([&] { decode_npy(bad_shape, "x.npy"); }, {"x.npy", "bad .npy header"});
}

TEST(Npy, ReadsByteStringsOfPython2Files) {
  const std::string data("pelvisspine\0", 12);  // '|S6': NUL-padded to 6 bytes
  EXPECT_EQ(decode_npy_strings(
                npy("{'descr': '|S6', 'fortran_order': False, 'shape': (2,), }", data), "s"),
            (std::vector<std::string>{"pelvis", "spine"}));
}

TEST(Npy, StringAndNumericArraysAreNotInterchangeable) {
  expect_error([] { decode_npy(encode_npy_strings({"a"}), "s"); }, {"s", "string array"});
  expect_error([] { decode_npy_strings(encode_npy(torch::ones(2)), "n"); },
               {"n", "numeric array"});
}

TEST(NpzReader, MissingKeyListsAvailableKeys) {
  expect_error([] { NpzReader(fixture("numpy_savez.npz")).tensor("betas"); },
               {"numpy_savez.npz", "'betas'", "kintree_table"});
}

TEST(NpzReader, ConcurrentReadsOfOneArchive) {
  const NpzReader reader(fixture("numpy_savez_compressed.npz"));
  const torch::Tensor expected = reader.tensor("f8");
  std::atomic<int> mismatches{0};
  at::parallel_for(0, 64, 1, [&](int64_t begin, int64_t end) {
    for (int64_t i = begin; i < end; ++i) mismatches += !torch::equal(reader.tensor("f8"), expected);
  });
  EXPECT_EQ(mismatches.load(), 0);
}

TEST(NpzReader, DtypeErrorsNameFileAndKey) {
  const auto dir = temp_dir("npz_dtype_error");
  NpzWriter writer;
  writer.add_strings("names", {"a"});
  writer.save((dir / "s.npz").string());
  expect_error([&] { NpzReader((dir / "s.npz").string()).tensor("names"); },
               {"s.npz", "'names'", "string array"});
}

TEST(NpzReader, RejectsMissingFileAndNonZip) {
  expect_error([] { NpzReader("/nonexistent/model.npz"); },
               {"/nonexistent/model.npz", "no such file"});
  const auto dir = temp_dir("npz_notzip");
  write_file_atomically((dir / "x.npz").string(), "this is not a zip archive at all");
  expect_error([&] { NpzReader((dir / "x.npz").string()); }, {"x.npz", "zip"});
}

TEST(NpzReader, RejectsTruncatedArchiveAndCorruptMember) {
  const auto dir = temp_dir("npz_truncated");
  NpzWriter writer;
  writer.add("a", torch::arange(1000, torch::kFloat32));
  writer.save((dir / "full.npz").string(), /*compress=*/true);
  const std::string bytes = read_file((dir / "full.npz").string());

  write_file_atomically((dir / "cut.npz").string(), bytes.substr(0, bytes.size() / 2));
  expect_error([&] { NpzReader((dir / "cut.npz").string()).tensor("a"); }, {"cut.npz"});

  // Damage the deflated data (it starts after the 30-byte local header and "a.npy").
  std::string damaged = bytes;
  for (size_t i = 60; i < 80; ++i) damaged[i] = static_cast<char>(~damaged[i]);
  write_file_atomically((dir / "damaged.npz").string(), damaged);
  NpzReader reader((dir / "damaged.npz").string());
  expect_error([&] { reader.tensor("a"); }, {"damaged.npz", "'a'", "corrupt"});
}

TEST(NpzReader, WrongCrcOfAStoredMemberIsCorruption) {
  const auto dir = temp_dir("npz_crc");
  NpzWriter writer;
  writer.add("a", torch::arange(1000, torch::kFloat32));
  writer.save((dir / "stored.npz").string(), /*compress=*/false);
  std::string bytes = read_file((dir / "stored.npz").string());
  EXPECT_TRUE(torch::equal(NpzReader((dir / "stored.npz").string()).tensor("a"), torch::arange(1000, torch::kFloat32)));
  // A flipped bit inside the stored array data: the zip structure stays valid.
  const auto magic = bytes.find("\x93NUMPY");
  ASSERT_NE(magic, std::string::npos);
  bytes[magic + 1000] = static_cast<char>(bytes[magic + 1000] ^ 0x10);
  write_file_atomically((dir / "flipped.npz").string(), bytes);
  expect_error([&] { NpzReader((dir / "flipped.npz").string()).tensor("a"); },
               {"flipped.npz", "'a'", "CRC-32"});
}

TEST(NpzReader, RejectsTwoMembersOfOneName) {
  expect_error([] { NpzReader reader(fixture("duplicate_member.npz")); },
               {"duplicate_member.npz", "member 'a.npy' appears more than once"});
}

}  // namespace
}  // namespace fskin::io

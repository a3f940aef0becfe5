// Bad dataset manifests and frames fail with fskin::Error naming the file and
// the field, before any work.
#include "fskin/data/dataset.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "fskin/data/dataset_frame.h"
#include "test_util.h"

namespace fskin {
namespace {

namespace fs = std::filesystem;

nlohmann::json good_manifest() {
  return {{"format", "fskin-dataset"},
          {"format_version", kDatasetFormatVersion},
          {"complete", true},
          {"joint_names", {"root", "tail_1", "tail_2"}},
          {"parents", {-1, 0, 1}},
          {"splits", {{"train", {"frames/train_0000.npz"}}}}};
}

fs::path write_manifest(const std::string& name, const nlohmann::json& manifest) {
  const auto dir = testing::temp_dir("dataset_" + name);
  std::ofstream(dir / "manifest.json") << manifest.dump();
  return dir;
}

TEST(Dataset, BadManifestFieldsNameTheFileAndTheField) {
  auto m = good_manifest();
  m.erase("parents");
  auto dir = write_manifest("no_parents", m);
  testing::expect_error([&] { Dataset::load_canonical(dir.string()); },
                        {(dir / "manifest.json").string(), "no field 'parents'"});

  m = good_manifest();
  m["joint_names"] = "root";
  dir = write_manifest("names_string", m);
  testing::expect_error([&] { Dataset::load_canonical(dir.string()); },
                        {"manifest.json", "field 'joint_names' must be a list of joint names", "string"});

  m = good_manifest();
  m["format_version"] = "two";
  dir = write_manifest("version_string", m);
  testing::expect_error([&] { Dataset::load_canonical(dir.string()); }, {"manifest.json", "wrong type"});

  dir = write_manifest("array", nlohmann::json::array());
  testing::expect_error([&] { Dataset::load_canonical(dir.string()); }, {"manifest.json", "not a JSON object"});
}

TEST(Dataset, ParentsMustFormATreeListedParentsFirst) {
  for (const auto& [parents, message] : std::vector<std::pair<std::vector<int64_t>, std::string>>{
           {{-1, 0, 99}, "parents[2] = 99"},
           {{-1, 2, 1}, "parents[1] = 2"},  // a cycle 1 -> 2 -> 1
           {{0, 0, 1}, "parents[0] = 0"},
           {{-1, -1, 1}, "parents[1] = -1"}}) {
    auto m = good_manifest();
    m["parents"] = parents;
    const auto dir = write_manifest("parents", m);
    testing::expect_error([&] { Dataset::load_canonical(dir.string()); }, {"manifest.json", message});
  }
}

TEST(Dataset, SplitEntriesStayInsideTheDataset) {
  for (const std::string entry : {"/etc/other/frame.npz", "../other/frames/train_0000.npz", ""}) {
    auto m = good_manifest();
    m["splits"]["train"] = {entry};
    const auto dir = write_manifest("escape", m);
    testing::expect_error([&] { Dataset::load(dir.string(), "train"); },
                          {"manifest.json", "split 'train' lists '" + entry + "'", "not a file inside"});
  }
  auto m = good_manifest();
  m["splits"]["train"] = 3;
  const auto dir = write_manifest("split_number", m);
  testing::expect_error([&] { Dataset::load(dir.string(), "train"); },
                        {"manifest.json: splits", "field 'train' must be a list of frame file names"});
}

DatasetFrame small_frame() {
  DatasetFrame f;
  f.points = torch::rand({10, 3});
  f.occupancy = torch::zeros({10}, torch::kUInt8);
  f.num_uniform = 5;
  f.bone_transforms = torch::eye(4).expand({3, 4, 4}).contiguous();
  f.bone_transforms_rest = f.bone_transforms.clone();
  f.pose = torch::zeros({3, 3});
  f.trans = torch::zeros({3});
  f.box = torch::tensor({{0.0f, 0.0f, 0.0f}, {1.0f, 1.0f, 1.0f}});
  return f;
}

TEST(DatasetFrame, ImplausibleOrMistypedFramesAreRejected) {
  small_frame().validate("ok.npz");
  auto f = small_frame();
  f.points = f.points.to(torch::kFloat64);
  testing::expect_error([&] { f.validate("f.npz"); }, {"f.npz: points must be float32", "Double"});
  f = small_frame();
  f.occupancy[3] = 255;
  testing::expect_error([&] { f.validate("f.npz"); }, {"f.npz: occupancy values must be 0", "255"});
  f = small_frame();
  f.bone_transforms = f.bone_transforms * 1e30;
  testing::expect_error([&] { f.validate("f.npz"); }, {"f.npz: bone_transforms", "implausible magnitude"});
  f = small_frame();
  f.points[0][0] = std::nanf("");
  testing::expect_error([&] { f.validate("f.npz"); }, {"f.npz: points"});
}

}  // namespace
}  // namespace fskin

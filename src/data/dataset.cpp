#include "fskin/data/dataset.h"

#include <torch/torch.h>

#include <filesystem>
#include <numeric>

#include <nlohmann/json.hpp>

#include "fskin/core/error.h"
#include "fskin/util/atomic_file.h"
#include "fskin/util/progress.h"

namespace fskin {

namespace {
nlohmann::json read_manifest(const std::string& dir) {
  const std::string manifest_path = (std::filesystem::path(dir) / "manifest.json").string();
  nlohmann::json manifest;
  try {
    manifest = nlohmann::json::parse(read_file(manifest_path));
  } catch (const nlohmann::json::exception& e) {
    fail("{}: not a valid dataset manifest ({})", manifest_path, e.what());
  }
  FSKIN_CHECK(manifest.is_object(), "{}: not an fskin dataset manifest (not a JSON object)", manifest_path);
  try {
    FSKIN_CHECK(manifest.value("format", "") == "fskin-dataset", "{}: not an fskin dataset manifest",
                manifest_path);
    FSKIN_CHECK(manifest.value("format_version", 0) == kDatasetFormatVersion,
                "{}: dataset format {} (this fskin reads format {}); rebuild it with `fskin data build`",
                manifest_path, manifest.value("format_version", 0), kDatasetFormatVersion);
    FSKIN_CHECK(manifest.value("complete", false),
                "{}: the build did not finish; re-run `fskin data build` to complete it", dir);
  } catch (const nlohmann::json::exception& e) {
    fail("{}: format, format_version or complete has the wrong type ({})", manifest_path, e.what());
  }
  return manifest;
}
// manifest[key] as T, or an fskin::Error naming the file, the field and what it must be.
template <typename T>
T manifest_field(const nlohmann::json& object, const std::string& key, const std::string& path,
                 const char* expected) {
  FSKIN_CHECK(object.contains(key), "{}: no field '{}' ({})", path, key, expected);
  try {
    return object.at(key).get<T>();
  } catch (const nlohmann::json::exception&) {
    fail("{}: field '{}' must be {}, got {}", path, key, expected, object.at(key).type_name());
  }
}

// A tree listed parents first: parents[0] = -1 and 0 <= parents[j] < j, which
// also rules out cycles.
void check_parents(const std::vector<int64_t>& parents, const std::string& path) {
  FSKIN_CHECK(!parents.empty(), "{}: the skeleton has no joints", path);
  FSKIN_CHECK(parents[0] == -1, "{}: parents[0] = {}: the first joint must be the root (parent -1)", path,
              parents[0]);
  for (size_t j = 1; j < parents.size(); ++j) {
    FSKIN_CHECK(parents[j] >= 0 && parents[j] < static_cast<int64_t>(j),
                "{}: parents[{}] = {} is not an earlier joint (joints are listed parents first, one root)", path,
                j, parents[j]);
  }
}

}  // namespace

Dataset Dataset::load_canonical(const std::string& dir) {
  namespace fs = std::filesystem;
  const auto manifest = read_manifest(dir);
  Dataset dataset;
  const std::string manifest_path = (fs::path(dir) / "manifest.json").string();
  dataset.joint_names_ = manifest_field<std::vector<std::string>>(manifest, "joint_names", manifest_path,
                                                                  "a list of joint names");
  dataset.parents_ = manifest_field<std::vector<int64_t>>(manifest, "parents", manifest_path,
                                                          "a list of parent joint indices");
  FSKIN_CHECK(dataset.parents_.size() == dataset.joint_names_.size(), "{}/manifest.json: {} parents for {} joints",
              dir, dataset.parents_.size(), dataset.joint_names_.size());
  check_parents(dataset.parents_, manifest_path);
  const std::string canonical_path = (fs::path(dir) / "canonical.npz").string();
  dataset.canonical_ = DatasetFrame::load(canonical_path, true);
  FSKIN_CHECK(dataset.canonical_.joints.defined() &&
                  dataset.canonical_.joints.size(0) == static_cast<int64_t>(dataset.parents_.size()),
              "{}: no canonical joints for the manifest's {} joints", canonical_path, dataset.parents_.size());
  return dataset;
}

Dataset Dataset::load(const std::string& dir, const std::string& split, bool with_meshes) {
  namespace fs = std::filesystem;
  const auto manifest = read_manifest(dir);
  const std::string manifest_path = (fs::path(dir) / "manifest.json").string();
  FSKIN_CHECK(manifest.contains("splits") && manifest["splits"].is_object() && manifest["splits"].contains(split),
              "{}/manifest.json: unknown split '{}' (train, val, test_within, test_ood)", dir, split);
  const auto files = manifest_field<std::vector<std::string>>(manifest["splits"], split, manifest_path + ": splits",
                                                              "a list of frame file names");
  for (const auto& file : files) {
    // Frames are files of this dataset: a relative path that stays inside it.
    const fs::path path(file);
    bool escapes = file.empty() || path.is_absolute();
    for (const auto& part : path) escapes = escapes || part == "..";
    FSKIN_CHECK(!escapes, "{}: split '{}' lists '{}', which is not a file inside the dataset directory",
                manifest_path, split, file);
  }
  Dataset dataset = load_canonical(dir);
  dataset.split_ = split;
  FSKIN_CHECK(!files.empty(), "{}: split '{}' has no frames", dir, split);
  ProgressBar progress("loading " + split, static_cast<int64_t>(files.size()), files.size() > 20);
  for (const auto& file : files) {
    dataset.frames_.push_back(DatasetFrame::load((fs::path(dir) / file).string(), with_meshes));
    const auto& frame = dataset.frames_.back();
    FSKIN_CHECK(frame.bone_transforms.size(0) == static_cast<int64_t>(dataset.joint_names_.size()),
                "{}/{}: {} bones, manifest says {}", dir, file, frame.bone_transforms.size(0),
                dataset.joint_names_.size());
    progress.advance();
  }
  return dataset;
}

const DatasetFrame& Dataset::frame(int64_t index) const {
  FSKIN_CHECK(index >= 0 && index < size(), "Dataset '{}': frame {} out of range [0, {})", split_,
              index, size());
  return frames_[static_cast<size_t>(index)];
}

DatasetBatch Dataset::sample_batch(int64_t frames, int64_t surface_points, int64_t uniform_points,
                                   Rng& rng) const {
  FSKIN_CHECK(frames > 0 && surface_points >= 0 && uniform_points >= 0 &&
                  surface_points + uniform_points > 0,
              "Dataset::sample_batch: need frames > 0 and points > 0 (got {} frames, {} + {} points)",
              frames, surface_points, uniform_points);
  // Distinct frames: a partial Fisher-Yates shuffle, refilled when exhausted.
  std::vector<int64_t> order(frames_.size());
  std::iota(order.begin(), order.end(), 0);
  DatasetBatch batch;
  size_t next = order.size();
  for (int64_t b = 0; b < frames; ++b) {
    if (next == order.size()) next = 0;
    const auto pick = next + static_cast<size_t>(rng.index(static_cast<int64_t>(order.size() - next)));
    std::swap(order[next], order[pick]);
    batch.frames.push_back(order[next++]);
  }
  std::vector<torch::Tensor> points, occupancy, bones, poses;
  for (const int64_t f : batch.frames) {
    const auto& frame = frames_[static_cast<size_t>(f)];
    const int64_t n_uniform = frame.num_uniform, n_surface = frame.num_points() - n_uniform;
    FSKIN_CHECK((surface_points == 0 || n_surface > 0) && (uniform_points == 0 || n_uniform > 0),
                "Dataset '{}': frame {} has {} surface and {} uniform points", split_, f, n_surface,
                n_uniform);
    auto index = torch::empty({surface_points + uniform_points}, torch::kInt64);
    int64_t* ip = index.data_ptr<int64_t>();
    for (int64_t k = 0; k < surface_points; ++k) *ip++ = n_uniform + rng.index(n_surface);
    for (int64_t k = 0; k < uniform_points; ++k) *ip++ = rng.index(n_uniform);
    points.push_back(frame.points.index_select(0, index));
    occupancy.push_back(frame.occupancy.index_select(0, index));
    bones.push_back(frame.bone_transforms);
    poses.push_back(frame.pose);
  }
  batch.points = torch::stack(points);
  batch.occupancy = torch::stack(occupancy).to(torch::kFloat32);
  batch.bone_transforms = torch::stack(bones);
  batch.pose = torch::stack(poses);
  return batch;
}

}  // namespace fskin

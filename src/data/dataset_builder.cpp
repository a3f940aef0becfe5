#include "fskin/data/dataset_builder.h"
#include "fskin/data/dataset.h"

#include <torch/torch.h>

#include <chrono>
#include <cmath>
#include <filesystem>

#include <nlohmann/json.hpp>

#include "fskin/body/smpl_skeleton.h"
#include "fskin/data/build_manifest.h"
#include "fskin/core/error.h"
#include "fskin/data/dataset_frame.h"
#include "fskin/data/inside_test.h"
#include "fskin/data/random.h"
#include "fskin/data/thin_parts.h"
#include "fskin/geometry/character_size.h"
#include "fskin/skeleton/forward_kinematics.h"
#include "fskin/util/atomic_file.h"
#include "fskin/util/progress.h"
#include "fskin/version.h"

namespace fskin {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

struct FramePlan {
  std::string split, file;
  const PoseSet* poses;
  int64_t pose_index;
};

nlohmann::json box_json(const Box& box) {
  return {{"min", box.min}, {"max", box.max}};
}

torch::Tensor box_tensor(const Box& box) {
  return torch::tensor({box.min[0], box.min[1], box.min[2], box.max[0], box.max[1], box.max[2]},
                       torch::kFloat32)
      .reshape({2, 3});
}

}  // namespace

void DatasetBuildOptions::validate() const {
  FSKIN_CHECK(!out_dir.empty(), "dataset build: --out is empty");
  sampling.validate();
  FSKIN_CHECK(val_fraction >= 0 && test_fraction >= 0 && val_fraction + test_fraction < 1,
              "dataset build: val fraction {} and test fraction {} must be >= 0 and sum below 1",
              val_fraction, test_fraction);
  FSKIN_CHECK(canonical_pose == "default" || canonical_pose == "da" || canonical_pose == "rest",
              "dataset build: canonical pose must be 'default', 'da' or 'rest', got '{}'", canonical_pose);
  FSKIN_CHECK(thin_surface_share >= 0 && thin_surface_share <= 1,
              "dataset build: the thin-surface share must be in [0, 1], got {}", thin_surface_share);
  FSKIN_CHECK(std::isfinite(thin_thickness) && thin_thickness > 0,
              "dataset build: the thin thickness must be positive, got {}", thin_thickness);
}

std::string DatasetBuildSummary::to_string() const {
  const int64_t n = std::max<int64_t>(frames_written, 1);
  return fmt::format(
      "{} frames written, {} already complete (train {}, val {}, test_within {}, test_ood {}); "
      "per frame: posing {:.3f} s, sampling {:.3f} s, inside test {:.3f} s, writing {:.3f} s",
      frames_written, frames_skipped, train, val, test_within, test_ood, posing_s / n,
      sampling_s / n, inside_test_s / n, writing_s / n);
}

std::string resolve_canonical_pose(const BodyModel& model, const std::string& name) {
  FSKIN_CHECK(name == "default" || name == "da" || name == "rest",
              "unknown canonical pose '{}' (expected 'default', 'da' or 'rest')", name);
  if (name != "default") return name;
  if (model.data().canonical_pose.defined()) return "model";
  return is_smpl_skeleton(model.data().joint_names) ? "da" : "rest";
}

torch::Tensor canonical_pose(const BodyModel& model, const std::string& name) {
  const std::string resolved = resolve_canonical_pose(model, name);
  if (resolved == "model") return model.data().canonical_pose.clone();
  if (resolved == "da") return da_pose(model.skeleton());
  return torch::zeros({model.num_joints(), 3});
}

DatasetBuildSummary build_dataset(const BodyModel& model, const PoseSet& poses,
                                  const PoseSet& ood_poses, const DatasetBuildOptions& options) {
  options.validate();
  const auto& names = model.data().joint_names;
  poses.validate(options.poses_source, model.num_joints(), names);
  if (ood_poses.size() > 0) ood_poses.validate(options.ood_poses_source, model.num_joints(), names);

  // The papers' noise sigma (0.01) is for bodies of about 1.7 m: scale it by
  // the model's size, whichever axis is its longest.
  SamplingOptions sampling = options.sampling;
  const double size = character_size(model.data().v_template, "dataset build: model");
  sampling.noise_sigma = options.sampling.noise_sigma * size / kReferenceCharacterSize;

  const auto canonical_aa = canonical_pose(model, options.canonical_pose);
  const auto canonical = model.pose(canonical_aa.unsqueeze(0));
  const auto canonical_bones = canonical.bone_transforms;  // [1, J, 4, 4] rest -> canonical
  const Mesh canonical_mesh{canonical.vertices[0].contiguous(), model.data().faces, {}};
  const Box canonical_box = mesh_bounds(canonical_mesh, sampling.box_scale);
  // Thickness barely changes with the pose: the thin faces are found once, in
  // the canonical pose, and the posed frames sample the same faces.
  const auto thin = options.thin_surface_share > 0
                        ? thin_faces(canonical_mesh, options.thin_thickness * size)
                        : torch::zeros({0}, torch::kInt64);

  // Contiguous blocks: train | val | test_within.
  const int64_t n = poses.size();
  const auto n_test = static_cast<int64_t>(std::llround(options.test_fraction * n));
  const auto n_val = static_cast<int64_t>(std::llround(options.val_fraction * n));
  FSKIN_CHECK(n - n_val - n_test > 0,
              "{}: {} poses leave no training frames after {} validation and {} test frames",
              options.poses_source, n, n_val, n_test);
  std::vector<FramePlan> plan;
  nlohmann::json splits = nlohmann::json::object();
  for (const auto& split : dataset_split_names()) splits[split] = nlohmann::json::array();
  const auto add = [&](const std::string& split, const PoseSet* set, int64_t index) {
    const auto count = static_cast<int64_t>(splits[split].size());
    const std::string file = fmt::format("{}_{:05d}.npz", split, count);
    splits[split].push_back(file);
    plan.push_back({split, file, set, index});
  };
  for (int64_t i = 0; i < n; ++i)
    add(i < n - n_val - n_test ? "train" : i < n - n_test ? "val" : "test_within", &poses, i);
  for (int64_t i = 0; i < ood_poses.size(); ++i) add("test_ood", &ood_poses, i);

  nlohmann::json manifest = {
      {"format", "fskin-dataset"},
      {"format_version", kDatasetFormatVersion},
      {"fskin_version", FSKIN_VERSION},
      {"model", options.model_source},
      {"poses", options.poses_source},
      {"ood_poses", options.ood_poses_source},
      {"num_joints", model.num_joints()},
      {"joint_names", names},
      {"parents", model.data().parents},
      {"num_vertices", model.num_vertices()},
      {"num_faces", model.data().faces.size(0)},
      {"canonical_pose", resolve_canonical_pose(model, options.canonical_pose)},
      {"canonical_box", box_json(canonical_box)},
      {"body_size", size},
      {"seed", options.seed},
      {"sampling",
       {{"uniform_points", sampling.uniform_points},
        {"surface_points", sampling.surface_points},
        {"box_scale", sampling.box_scale},
        {"noise_sigma", sampling.noise_sigma},
        {"noise_sigma_at_1_7m", options.sampling.noise_sigma},
        {"surface_sampling", "area-uniform"},
        {"inside_test", fmt::format("embree signed crossings, majority of {} rays",
                                    InsideTest::kRays)}}},
      {"val_fraction", options.val_fraction},
      {"test_fraction", options.test_fraction},
      {"frames", plan.size()},
      {"counts",
       {{"train", splits["train"].size()},
        {"val", splits["val"].size()},
        {"test_within", splits["test_within"].size()},
        {"test_ood", splits["test_ood"].size()}}},
      {"splits", splits},
  };

  if (options.thin_surface_share > 0) {
    // Only then: datasets built without it keep their manifest, and resume.
    manifest["sampling"]["train_surface_sampling"] = fmt::format(
        "{:.0f} % on the {} faces thinner than {:.3g} ({} x the size), the rest area-uniform",
        100 * options.thin_surface_share, thin.size(0), options.thin_thickness * size, options.thin_thickness);
    manifest["sampling"]["thin_surface_share"] = options.thin_surface_share;
    manifest["sampling"]["thin_thickness"] = options.thin_thickness;
    manifest["sampling"]["thin_faces"] = thin.size(0);
  }

  const fs::path dir(options.out_dir);
  const BuildManifest build_manifest(options.out_dir, manifest);

  const fs::path canonical_path = dir / "canonical.npz";
  if (!fs::exists(canonical_path)) {
    DatasetFrame frame;
    frame.points = torch::zeros({0, 3});
    frame.occupancy = torch::zeros({0}, torch::kUInt8);
    frame.bone_transforms = torch::eye(4).expand({model.num_joints(), 4, 4}).contiguous();
    frame.bone_transforms_rest = canonical_bones[0];
    frame.pose = canonical_aa;
    frame.trans = torch::zeros({3});
    frame.box = box_tensor(canonical_box);
    frame.vertices = canonical_mesh.vertices;
    frame.faces = canonical_mesh.faces;
    frame.joints = canonical.joints[0];
    frame.save(canonical_path.string());
  }

  DatasetBuildSummary summary;
  ProgressBar progress("building " + options.out_dir, static_cast<int64_t>(plan.size()),
                       options.progress);
  for (size_t f = 0; f < plan.size(); ++f) {
    const auto& item = plan[f];
    const std::string path = (dir / item.file).string();
    if (fs::exists(path)) {
      ++summary.frames_skipped;
      progress.advance(1, "skipped " + item.file);
      continue;
    }
    DatasetFrame frame;
    auto start = Clock::now();
    const auto pose = item.poses->poses[item.pose_index];
    const auto trans = item.poses->trans[item.pose_index];
    const auto& moved = item.poses->joint_translations;
    const auto posed = model.pose(pose.unsqueeze(0), {}, trans.unsqueeze(0),
                                  moved.defined() ? moved[item.pose_index].unsqueeze(0) : torch::Tensor());
    frame.bone_transforms_rest = posed.bone_transforms[0].contiguous();
    frame.bone_transforms =
        relative_bone_transforms(posed.bone_transforms, canonical_bones)[0].contiguous();
    frame.pose = pose.contiguous();
    frame.trans = trans.contiguous();
    const Mesh mesh{posed.vertices[0].contiguous(), model.data().faces, {}};
    frame.vertices = mesh.vertices;
    frame.faces = mesh.faces;
    summary.posing_s += seconds_since(start);

    start = Clock::now();
    Rng rng = Rng::for_item(options.seed, f);
    frame.points = item.split == "train" && thin.size(0) > 0
                       ? sample_frame_points(mesh, sampling, rng, thin, options.thin_surface_share)
                       : sample_frame_points(mesh, sampling, rng);
    frame.num_uniform = sampling.uniform_points;
    frame.box = box_tensor(mesh_bounds(mesh, sampling.box_scale));
    summary.sampling_s += seconds_since(start);

    start = Clock::now();
    frame.occupancy = InsideTest(mesh).contains(frame.points);
    summary.inside_test_s += seconds_since(start);

    start = Clock::now();
    frame.save(path);
    summary.writing_s += seconds_since(start);
    ++summary.frames_written;
    progress.advance(1, item.file);
  }
  progress.finish();
  build_manifest.mark_complete();
  summary.train = static_cast<int64_t>(splits["train"].size());
  summary.val = static_cast<int64_t>(splits["val"].size());
  summary.test_within = static_cast<int64_t>(splits["test_within"].size());
  summary.test_ood = static_cast<int64_t>(splits["test_ood"].size());
  return summary;
}

}  // namespace fskin

// fskin poses: generate seeded pose sets for a model's skeleton: the built-in
// motions of SMPL skeletons and of the built-in quadruped, or, for any other
// skeleton, motions inside the joint ranges of a pose file (--ranges-from).
#include <torch/torch.h>

#include <algorithm>
#include <cstdio>
#include <iterator>
#include <map>

#include "cli/commands.h"
#include "fskin/core/error.h"
#include "fskin/body/body_model.h"
#include "fskin/data/clip_selection.h"
#include "fskin/data/pose_generators.h"
#include "fskin/import/motion_import.h"

namespace fskin::cli {
namespace {

JointRanges ranges_from(const std::string& path, const std::string& model_path, const std::vector<std::string>& names) {
  const auto poses = PoseSet::load(path);
  poses.validate(path + " (for " + model_path + ")", static_cast<int64_t>(names.size()), names);
  return ranges_of_poses(poses, path);
}

}  // namespace

void register_poses(CLI::App& app) {
  struct Options {
    std::string model, out, ranges_from, input, name_map;
    std::string train_selection, test_selection, train_out, test_out;
    int64_t sequences = 10, frames = 30, count = 50;
    uint64_t seed = 0;
  };
  auto opt = std::make_shared<Options>();
  auto* cmd = app.add_subcommand("poses", "Generate pose sets (.npz) for a model's skeleton");
  cmd->require_subcommand(1);

  auto* train = cmd->add_subcommand(
      "train", "Natural motions (walks, arm swings, bends) within moderate joint ranges");
  train->add_option("--model", opt->model, "SMPL-format model .npz (for the joint names)")->required();
  train->add_option("--ranges-from", opt->ranges_from,
                    "pose file .npz (e.g. the character's imported clips) whose per-joint ranges bound the "
                    "motions; needed for skeletons without built-in motions");
  train->add_option("--out", opt->out, "output pose file .npz")->required();
  train->add_option("--sequences", opt->sequences, "number of motion sequences")
      ->check(CLI::PositiveNumber);
  train->add_option("--frames", opt->frames, "frames per sequence")->check(CLI::PositiveNumber);
  train->add_option("--seed", opt->seed, "random seed");
  train->callback([opt] {
    const auto model = BodyModel::load(opt->model);
    const auto& names = model.data().joint_names;
    const TrainingPoseOptions options{opt->sequences, opt->frames, opt->seed};
    const auto set = opt->ranges_from.empty()
                         ? make_training_poses(names, options)
                         : make_training_poses(names, ranges_from(opt->ranges_from, opt->model, names), options);
    set.save(opt->out);
    std::printf("wrote %s: %lld training poses (%lld sequences x %lld frames), %lld joints\n",
                opt->out.c_str(), static_cast<long long>(set.size()),
                static_cast<long long>(opt->sequences), static_cast<long long>(opt->frames),
                static_cast<long long>(set.num_joints()));
  });

  auto* ood = cmd->add_subcommand(
      "ood", "Extreme poses outside the training ranges (leg raises, crossed arms, deep bends)");
  ood->add_option("--model", opt->model, "SMPL-format model .npz (for the joint names)")->required();
  ood->add_option("--ranges-from", opt->ranges_from,
                  "pose file .npz whose per-joint ranges the poses go beyond (as for poses train)");
  ood->add_option("--out", opt->out, "output pose file .npz")->required();
  ood->add_option("--count", opt->count, "number of poses")->check(CLI::PositiveNumber);
  ood->add_option("--seed", opt->seed, "random seed");
  ood->callback([opt] {
    const auto model = BodyModel::load(opt->model);
    const auto& names = model.data().joint_names;
    const auto ranges =
        opt->ranges_from.empty() ? training_ranges(names) : ranges_from(opt->ranges_from, opt->model, names);
    const OodPoseOptions options{opt->count, opt->seed};
    const auto set = opt->ranges_from.empty() ? make_ood_poses(names, options) : make_ood_poses(names, ranges, options);
    set.save(opt->out);
    double smallest_excess = INFINITY;
    for (int64_t i = 0; i < set.size(); ++i) smallest_excess = std::min(smallest_excess, range_excess(ranges, set.poses[i]));
    std::printf("wrote %s: %lld out-of-distribution poses, each >= %.2f rad beyond the training "
                "ranges\n",
                opt->out.c_str(), static_cast<long long>(set.size()), smallest_excess);
  });

  auto* select = cmd->add_subcommand(
      "select", "Pick clips and frame ranges out of a clips file into a training and a test pose file");
  select->add_option("CLIPS", opt->input, "clips file .npz (from `fskin import --clips` or `fskin character --clips`)")
      ->required();
  select->add_option("--train", opt->train_selection,
                     "clips for training: NAME[,NAME:FIRST-LAST,NAME:FIRST-...] (frames from 0 within each clip, "
                     "inclusive)");
  select->add_option("--out-train", opt->train_out, "pose file .npz the --train selection goes to");
  select->add_option("--test", opt->test_selection, "clips for testing, as --train; must not share frames with it");
  select->add_option("--out-test", opt->test_out, "pose file .npz the --test selection goes to");
  select->callback([opt] {
    FSKIN_CHECK(!opt->train_selection.empty() || !opt->test_selection.empty(),
                "fskin poses select: give --train and/or --test");
    FSKIN_CHECK(opt->train_selection.empty() == opt->train_out.empty(),
                "fskin poses select: --train and --out-train go together");
    FSKIN_CHECK(opt->test_selection.empty() == opt->test_out.empty(),
                "fskin poses select: --test and --out-test go together");
    const auto clips = PoseSet::load(opt->input);
    std::vector<int64_t> train_frames;
    if (!opt->train_selection.empty())
      train_frames = selected_frames(clips, parse_clip_selection(opt->train_selection), opt->input);
    if (!opt->test_selection.empty() && !train_frames.empty()) {
      const auto test_frames = selected_frames(clips, parse_clip_selection(opt->test_selection), opt->input);
      std::vector<int64_t> shared;
      std::vector<int64_t> sorted_train = train_frames, sorted_test = test_frames;
      std::sort(sorted_train.begin(), sorted_train.end());
      std::sort(sorted_test.begin(), sorted_test.end());
      std::set_intersection(sorted_train.begin(), sorted_train.end(), sorted_test.begin(), sorted_test.end(),
                            std::back_inserter(shared));
      FSKIN_CHECK(shared.empty(),
                  "fskin poses select: --train '{}' and --test '{}' share {} frame(s) of {}; a test set must hold "
                  "frames the training never sees",
                  opt->train_selection, opt->test_selection, shared.size(), opt->input);
    }
    for (const auto& [selection, out] :
         {std::pair{opt->train_selection, opt->train_out}, std::pair{opt->test_selection, opt->test_out}}) {
      if (selection.empty()) continue;
      const auto set = select_clips(clips, parse_clip_selection(selection), opt->input);
      set.save(out);
      std::string names;
      for (const auto& name : set.clip_names) names += (names.empty() ? "" : ", ") + name;
      std::printf("wrote %s: %lld poses (%s)\n", out.c_str(), static_cast<long long>(set.size()), names.c_str());
    }
  });

  auto* import = cmd->add_subcommand(
      "import", "Motion capture for a model: BVH (retargeted by joint name) or AMASS/SMPL-style .npz");
  import->add_option("FILE", opt->input, "motion file (.bvh or .npz with poses [T, 3J], trans [T, 3])")->required();
  import->add_option("--model", opt->model, "model .npz the poses are for")->required();
  import->add_option("--out", opt->out, "output pose file .npz")->required();
  import->add_option("--map", opt->name_map, "BVH only: text file of 'bvh_joint=model_joint' lines");
  import->callback([opt] {
    const auto model = BodyModel::load(opt->model);
    const auto skeleton = model.skeleton();
    const bool bvh = opt->input.size() > 4 && opt->input.substr(opt->input.size() - 4) == ".bvh";
    FSKIN_CHECK(bvh || opt->name_map.empty(), "fskin poses import: --map applies to BVH files only");
    const auto motion = bvh ? import_bvh(opt->input, skeleton,
                                         opt->name_map.empty() ? std::map<std::string, std::string>{}
                                                               : read_name_map(opt->name_map))
                            : import_amass(opt->input, skeleton);
    motion.poses.save(opt->out);
    std::printf("wrote %s: %lld poses at %.4g fps for %lld joints\n", opt->out.c_str(),
                static_cast<long long>(motion.poses.size()), motion.fps, static_cast<long long>(skeleton.num_joints()));
    for (const auto& note : motion.notes) std::printf("  %s\n", note.c_str());
  });
}

}  // namespace fskin::cli

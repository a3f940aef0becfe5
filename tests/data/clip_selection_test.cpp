// Picking clips and frame ranges out of a clips file (`fskin poses select`).
#include "fskin/data/clip_selection.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cstdlib>
#include <fstream>
#include <iterator>

#include "test_util.h"

namespace fskin {
namespace {

// Three clips of 4, 3 and 5 frames; every pose's first value is its index.
PoseSet three_clips() {
  PoseSet set;
  set.poses = torch::zeros({12, 2, 3});
  set.poses.select(2, 0).select(1, 0).copy_(torch::arange(12, torch::kFloat32));
  set.trans = torch::arange(36, torch::kFloat32).reshape({12, 3});
  set.joint_names = {"a", "b"};
  set.clip_names = {"walk", "idle", "run"};
  set.clip_starts = {0, 4, 7};
  return set;
}

std::vector<float> first_values(const PoseSet& set) {
  const auto v = set.poses.select(2, 0).select(1, 0).contiguous();
  return {v.data_ptr<float>(), v.data_ptr<float>() + v.numel()};
}

TEST(ClipSelection, ParsesNamesAndInclusiveRanges) {
  const auto ranges = parse_clip_selection("walk,run:1-3,idle:2-");
  ASSERT_EQ(ranges.size(), 3u);
  EXPECT_EQ(ranges[0].clip, "walk");
  EXPECT_EQ(ranges[0].last, -1);
  EXPECT_EQ(ranges[1].clip, "run");
  EXPECT_EQ(ranges[1].first, 1);
  EXPECT_EQ(ranges[1].last, 3);
  EXPECT_EQ(ranges[2].first, 2);
  EXPECT_EQ(ranges[2].last, -1);
  // Names may hold colons of their own (Mixamo's "Armature|mixamo.com|Layer0" has bars, others colons).
  EXPECT_EQ(parse_clip_selection("rig:walk:0-1")[0].clip, "rig:walk");
  for (const std::string bad : {"", "walk,", ",walk", "walk:3-1", "walk:x-2", "walk:-2", ":0-1", "walk:12"})
    testing::expect_error([&] { parse_clip_selection(bad); }, {"clip selection"});
}

TEST(ClipSelection, TakesTheFramesInTheOrderGivenWithClipNames) {
  const auto set = select_clips(three_clips(), parse_clip_selection("run:1-3,walk"), "clips.npz");
  EXPECT_EQ(first_values(set), (std::vector<float>{8, 9, 10, 0, 1, 2, 3}));
  EXPECT_EQ(set.clip_names, (std::vector<std::string>{"run:1-3", "walk"}));
  EXPECT_EQ(set.clip_starts, (std::vector<int64_t>{0, 3}));
  EXPECT_TRUE(torch::equal(set.trans[0], three_clips().trans[8]));
  EXPECT_EQ(set.joint_names, three_clips().joint_names);
  set.validate("selection");
  // "idle:1-" runs to the clip's end and not into the next clip.
  EXPECT_EQ(first_values(select_clips(three_clips(), parse_clip_selection("idle:1-"), "clips.npz")),
            (std::vector<float>{5, 6}));
}

TEST(ClipSelection, NamesTheFileAndWhatItHas) {
  testing::expect_error([] { selected_frames(three_clips(), parse_clip_selection("jump"), "clips.npz"); },
                        {"clips.npz", "'jump'", "walk (4 frames)", "idle (3 frames)", "run (5 frames)"});
  testing::expect_error([] { selected_frames(three_clips(), parse_clip_selection("idle:1-3"), "clips.npz"); },
                        {"clips.npz", "'idle'", "0-2", "1-3"});
  PoseSet plain = three_clips();
  plain.clip_names.clear();
  plain.clip_starts.clear();
  testing::expect_error([&] { selected_frames(plain, parse_clip_selection("walk"), "poses.npz"); },
                        {"poses.npz", "no clip names"});
}

int run_cli(const std::string& arguments, const std::filesystem::path& log) {
  return std::system((std::string(FSKIN_CLI_PATH) + " " + arguments + " > " + log.string() + " 2>&1").c_str());
}

TEST(PosesSelectCommand, WritesTrainingAndTestFilesAndRefusesSharedFrames) {
  const auto dir = testing::temp_dir("poses_select");
  const auto clips = (dir / "clips.npz").string(), train = (dir / "train.npz").string(),
             test = (dir / "test.npz").string();
  three_clips().save(clips);
  ASSERT_EQ(run_cli("poses select " + clips + " --train walk,idle:0-1 --out-train " + train + " --test run --out-test " +
                        test,
                    dir / "log"),
            0);
  EXPECT_EQ(first_values(PoseSet::load(train)), (std::vector<float>{0, 1, 2, 3, 4, 5}));
  EXPECT_EQ(first_values(PoseSet::load(test)), (std::vector<float>{7, 8, 9, 10, 11}));
  EXPECT_NE(run_cli("poses select " + clips + " --train walk --out-train " + train + " --test walk:3-3 --out-test " +
                        test,
                    dir / "log"),
            0);
  const std::string log = [&] {
    std::ifstream in(dir / "log");
    return std::string(std::istreambuf_iterator<char>(in), {});
  }();
  EXPECT_NE(log.find("share 1 frame"), std::string::npos) << log;
  EXPECT_NE(run_cli("poses select " + clips + " --train walk", dir / "log"), 0);  // no --out-train
}

}  // namespace
}  // namespace fskin

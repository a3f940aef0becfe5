#include "fskin/import/motion_import.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "fskin/body/smpl_skeleton.h"
#include "fskin/io/npz.h"
#include "fskin/skeleton/rotations.h"
#include "fskin/util/atomic_file.h"
#include "test_util.h"

namespace fskin {
namespace {

namespace fs = std::filesystem;

Skeleton chain() {
  return Skeleton{{"root", "mid", "tip"}, {-1, 0, 1}, torch::tensor({{0.f, 0.f, 0.f}, {0.f, 1.f, 0.f}, {0.f, 2.f, 0.f}})};
}

// A 20-unit BVH chain (centimetres, say) with an extra joint the model lacks.
const char* kBvh = R"(HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Knee
  {
    OFFSET 0 10 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT Extra
    {
      OFFSET 0 5 0
      CHANNELS 3 Zrotation Xrotation Yrotation
      JOINT Foot
      {
        OFFSET 0 5 0
        CHANNELS 3 Zrotation Xrotation Yrotation
        End Site
        {
          OFFSET 0 2 0
        }
      }
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.04
0 0 0  0 0 0  0 0 0  0 0 0  0 0 0
10 20 30  90 0 0  0 30 0  0 0 45  -20 0 0
)";

torch::Tensor rotation(double x, double y, double z, const char* order) {
  // Product in `order` of axis rotations by the given degrees.
  auto r = torch::eye(3, torch::kFloat64);
  for (const char* c = order; *c; ++c) {
    auto aa = torch::zeros({3}, torch::kFloat64);
    const int axis = *c - 'X';
    aa[axis] = (axis == 0 ? x : axis == 1 ? y : z) * M_PI / 180.0;
    r = torch::matmul(r, axis_angle_to_matrix(aa));
  }
  return r;
}

TEST(BvhImport, RetargetsByNameFoldsExtraJointsAndScalesTheRootTranslation) {
  const auto dir = testing::temp_dir("bvh_import");
  const auto path = (dir / "walk.bvh").string();
  write_file_atomically(path, kBvh);
  const auto motion = import_bvh(path, chain(), {{"Hips", "root"}, {"Knee", "mid"}, {"Foot", "tip"}});
  ASSERT_EQ(motion.poses.size(), 2);
  EXPECT_NEAR(motion.fps, 25.0, 1e-9);
  EXPECT_LT(motion.poses.poses[0].abs().max().item<float>(), 1e-7);
  const auto r = axis_angle_to_matrix(motion.poses.poses[1].to(torch::kFloat64));
  EXPECT_LT((r[0] - rotation(0, 0, 90, "ZXY")).abs().max().item<double>(), 1e-6);
  EXPECT_LT((r[1] - rotation(30, 0, 0, "ZXY")).abs().max().item<double>(), 1e-6);
  // tip: the Extra joint's rotation folded in before the Foot's.
  EXPECT_LT((r[2] - torch::matmul(rotation(0, 45, 0, "ZXY"), rotation(0, 0, -20, "ZXY"))).abs().max().item<double>(), 1e-6);
  // The BVH joints span 20 units, the model's 2.
  EXPECT_LT((motion.poses.trans[1] - torch::tensor({1.f, 2.f, 3.f})).abs().max().item<float>(), 1e-5);
  bool folded_note = false;
  for (const auto& note : motion.notes) folded_note |= note.find("Extra") != std::string::npos;
  EXPECT_TRUE(folded_note);
  fs::remove_all(dir);
}

TEST(BvhImport, BadFilesNameTheFileAndTheProblem) {
  const auto dir = testing::temp_dir("bvh_bad");
  const auto path = (dir / "bad.bvh").string();
  testing::expect_error([&] { import_bvh(path, chain()); }, {"bad.bvh"});
  std::string text = kBvh;
  write_file_atomically(path, text.replace(text.find("0.04"), 4, "abc"));
  testing::expect_error([&] { import_bvh(path, chain()); }, {"bad.bvh", "'abc'"});
  write_file_atomically(path, kBvh);
  testing::expect_error([&] { import_bvh(path, chain()); }, {"bad.bvh", "root 'root'", "--map"});
  write_file_atomically((dir / "map.txt").string(), "Hips=root\n# comment\nKnee = mid\n");
  const auto map = read_name_map((dir / "map.txt").string());
  EXPECT_EQ(map.size(), 2u);
  EXPECT_EQ(map.at("Knee"), "mid");  // spaces around '=' are not part of the names
  write_file_atomically((dir / "map.txt").string(), "Hips root\n");
  testing::expect_error([&] { read_name_map((dir / "map.txt").string()); }, {"map.txt:1", "file_joint=model_joint"});
  fs::remove_all(dir);
}

TEST(AmassImport, SmplHFilesDriveTheSmplBodyJoints) {
  const auto dir = testing::temp_dir("amass_import");
  const auto path = (dir / "seq.npz").string();
  const auto poses = torch::randn({4, 52 * 3}) * 0.3;
  io::NpzWriter npz;
  npz.add("poses", poses);
  npz.add("trans", torch::ones({4, 3}));
  npz.add("mocap_framerate", torch::tensor(120.0));
  npz.save(path, false);
  Skeleton smpl{smpl_joint_names(), smpl_parents(), torch::zeros({24, 3})};
  const auto motion = import_amass(path, smpl);
  EXPECT_DOUBLE_EQ(motion.fps, 120.0);
  EXPECT_TRUE(torch::equal(motion.poses.poses.narrow(1, 0, 22), poses.view({4, 52, 3}).narrow(1, 0, 22)));
  EXPECT_EQ(motion.poses.poses.narrow(1, 22, 2).abs().max().item<float>(), 0.0f);
  EXPECT_TRUE(torch::equal(motion.poses.trans, torch::ones({4, 3})));
  testing::expect_error([&] { import_amass(path, chain()); }, {"seq.npz", "52 joints", "3 joints"});
  fs::remove_all(dir);
}

}  // namespace
}  // namespace fskin

// The game-style test characters: low-poly, thin flat parts, painted weights,
// weightless and leaf bones, clips.
#include "fskin/data/lowpoly_character.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <cmath>
#include <map>

#include "fskin/body/smpl_skeleton.h"
#include "fskin/data/inside_test.h"
#include "fskin/data/clip_selection.h"
#include "fskin/data/pose_generators.h"
#include "fskin/geometry/mesh_topology.h"
#include "fskin/training/train_config.h"
#include "test_util.h"

namespace fskin {
namespace {

LowPolyOptions options(LowPolyKind kind, uint64_t seed = 0) {
  LowPolyOptions o;
  o.kind = kind;
  o.seed = seed;
  return o;
}

class LowPoly : public ::testing::TestWithParam<LowPolyKind> {};

// The largest angle between the normals of two faces that share an edge.
double max_dihedral_angle_degrees(const Mesh& mesh) {
  const auto v = mesh.vertices.to(torch::kFloat64);
  const auto f = mesh.faces;
  const auto a = v.index({f.select(1, 0)}), b = v.index({f.select(1, 1)}), c = v.index({f.select(1, 2)});
  const auto normals = torch::nn::functional::normalize(torch::cross(b - a, c - a, 1),
                                                        torch::nn::functional::NormalizeFuncOptions().dim(1));
  std::map<std::pair<int64_t, int64_t>, int64_t> first_face;
  double largest = 0;
  const auto* fp = f.data_ptr<int64_t>();
  for (int64_t i = 0; i < f.size(0); ++i)
    for (int e = 0; e < 3; ++e) {
      const auto key = std::minmax(fp[3 * i + e], fp[3 * i + (e + 1) % 3]);
      const auto [it, inserted] = first_face.emplace(key, i);
      if (inserted) continue;
      const double cosine = std::clamp(normals[i].dot(normals[it->second]).item<double>(), -1.0, 1.0);
      largest = std::max(largest, std::acos(cosine) * 180.0 / M_PI);
    }
  return largest;
}

double extent(const torch::Tensor& points, int axis) {
  const auto p = points.select(1, axis);
  return (p.max() - p.min()).item<double>();
}

TEST_P(LowPoly, IsAFewHundredFacetedVerticesInClosedOutwardFacingParts) {
  const auto character = make_lowpoly_character(options(GetParam()));
  const BodyModel model(character.model, lowpoly_kind_name(GetParam()));
  EXPECT_GE(model.num_vertices(), 200);
  EXPECT_LE(model.num_vertices(), 3000);
  const auto mesh = model.template_mesh();
  // Separate closed parts, each a genus-0 surface facing outward.
  const auto topology = analyze_topology(mesh);
  EXPECT_TRUE(topology.is_closed_manifold());
  const auto parts = connected_components(mesh);
  EXPECT_GE(parts.count, 10);
  EXPECT_EQ(topology.euler_characteristic(), 2 * parts.count);
  for (int64_t c = 0; c < parts.count; ++c) {
    const Mesh part{mesh.vertices, mesh.faces.index({parts.face_labels == c}), {}};
    EXPECT_GT(signed_volume(part), 0.0) << "part " << c << " faces inward";
  }
  // Sharp creases: neighbouring faces meet at large angles somewhere (a
  // smooth body has none above ~30 degrees at this vertex count).
  EXPECT_GT(max_dihedral_angle_degrees(mesh), 60.0);
}

TEST_P(LowPoly, HasGameRigBonesAndPaintedWeights) {
  const auto character = make_lowpoly_character(options(GetParam()));
  const auto& m = character.model;
  const auto& names = m.joint_names;
  EXPECT_FALSE(is_smpl_skeleton(names));
  EXPECT_EQ(builtin_motions(names), "");
  // A weightless root on the ground, the hips hanging from it.
  EXPECT_EQ(m.parents[0], -1);
  EXPECT_EQ(m.weights.select(1, 0).abs().max().item<float>(), 0.0f);
  EXPECT_LT(m.rest_joints[0].norm().item<float>(), 1e-6);
  // Leaf bones without vertices: the *_end / *_End joints.
  int leaves = 0;
  for (size_t j = 0; j < names.size(); ++j) {
    const bool leaf = std::find(m.parents.begin(), m.parents.end(), static_cast<int64_t>(j)) == m.parents.end();
    if (names[j].find("_end") != std::string::npos || names[j].find("_End") != std::string::npos) {
      EXPECT_TRUE(leaf) << names[j];
      EXPECT_EQ(m.weights.select(1, j).max().item<float>(), 0.0f) << names[j];
      ++leaves;
    }
  }
  EXPECT_GE(leaves, 5);
  // Painted: most vertices belong to one bone, the rest to two at 50/50.
  const auto largest = std::get<0>(m.weights.max(1));
  EXPECT_GT((largest == 1.0f).to(torch::kFloat).mean().item<float>(), 0.7f);
  EXPECT_TRUE(((largest == 1.0f) | (largest == 0.5f)).all().item<bool>());
  EXPECT_LT((m.weights.sum(1) - 1).abs().max().item<float>(), 1e-6);
}

// The thinnest extent of the vertices that `bone` drives alone.
double thickness_of_part(const LowPolyCharacter& c, const std::string& bone) {
  const auto& names = c.model.joint_names;
  const auto j = std::find(names.begin(), names.end(), bone) - names.begin();
  const auto vertices = c.model.v_template.index({c.model.weights.select(1, j) == 1.0f});
  EXPECT_GT(vertices.size(0), 0) << bone;
  // Thickness along the part's smallest principal direction.
  const auto centred = vertices.to(torch::kFloat64) - vertices.to(torch::kFloat64).mean(0);
  const auto directions = std::get<2>(torch::linalg_svd(centred, false));
  const auto along = centred.matmul(directions[2]);
  return (along.max() - along.min()).item<double>();
}

TEST(LowPolyCharacter, ThinFlatPartsAreAboutOnePercentOfTheSizeThick) {
  const auto human = make_lowpoly_character(options(LowPolyKind::Humanoid));
  const auto fox = make_lowpoly_character(options(LowPolyKind::Animal));
  const double height = extent(human.model.v_template, 1), length = extent(fox.model.v_template, 0);
  EXPECT_NEAR(height, 1.8, 1e-3);
  EXPECT_NEAR(length, 0.9, 1e-3);
  EXPECT_LT(thickness_of_part(human, "LeftEar") / height, 0.008);
  EXPECT_LT(thickness_of_part(human, "Cape2") / height, 0.013);
  EXPECT_LT(thickness_of_part(fox, "ear_tip.L") / length, 0.01);
  EXPECT_LT(thickness_of_part(fox, "tail.003") / length, 0.015);
}

TEST(LowPolyCharacter, FacesItsOwnForwardAxis) {
  // The humanoid faces +z with its left along +x; the fox faces +x with its left along -z.
  const auto human = make_lowpoly_character(options(LowPolyKind::Humanoid)).model;
  const auto fox = make_lowpoly_character(options(LowPolyKind::Animal)).model;
  const auto joint = [](const BodyModelData& m, const std::string& name) {
    return m.rest_joints[std::find(m.joint_names.begin(), m.joint_names.end(), name) - m.joint_names.begin()];
  };
  EXPECT_GT(joint(human, "LeftToe_End")[2].item<float>(), joint(human, "LeftFoot")[2].item<float>() + 0.1);
  EXPECT_GT(joint(human, "LeftHand")[0].item<float>(), 0.5);
  EXPECT_GT(joint(fox, "nose_end")[0].item<float>(), 0.3);
  EXPECT_LT(joint(fox, "tail_end")[0].item<float>(), -0.3);
  EXPECT_LT(joint(fox, "thigh.L")[2].item<float>(), -0.03);
  EXPECT_GT(joint(fox, "thigh.R")[2].item<float>(), 0.03);
}

TEST_P(LowPoly, ClipsAreNamedAndTheRunGoesBeyondTheOthers) {
  const auto character = make_lowpoly_character(options(GetParam()));
  const auto& clips = character.clips;
  const bool human = GetParam() == LowPolyKind::Humanoid;
  const std::vector<std::string> expected =
      human ? std::vector<std::string>{"idle", "walk", "wave", "run"} : std::vector<std::string>{"idle", "walk", "run"};
  EXPECT_EQ(clips.clip_names, expected);
  EXPECT_EQ(clips.joint_names, character.model.joint_names);
  clips.validate("clips", static_cast<int64_t>(character.model.parents.size()), character.model.joint_names);
  // The run leaves the other clips' joint ranges by more than the OOD margin.
  const auto training = select_clips(clips, parse_clip_selection(human ? "idle,walk,wave" : "idle,walk"), "clips");
  const auto run = select_clips(clips, parse_clip_selection("run"), "clips");
  const auto ranges = ranges_of_poses(training, "training clips");
  double most = 0;
  for (int64_t i = 0; i < run.size(); ++i) most = std::max(most, range_excess(ranges, run.poses[i]));
  EXPECT_GT(most, kOodMargin);
  // Posed with its clips, the character stays on and above the ground.
  const BodyModel model(character.model, "lowpoly");
  const auto posed = model.pose(clips.poses, {}, clips.trans);
  EXPECT_TRUE(torch::isfinite(posed.vertices).all().item<bool>());
  const auto lowest = std::get<0>(posed.vertices.select(2, 1).min(1));
  EXPECT_GT(lowest.min().item<float>(), human ? -0.15 : -0.08);
}

TEST_P(LowPoly, ScalesAndVariesWithTheSeedDeterministically) {
  auto big = options(GetParam());
  big.size = 17.0;
  const auto a = make_lowpoly_character(big), b = make_lowpoly_character(big);
  EXPECT_TRUE(torch::equal(a.model.v_template, b.model.v_template));
  EXPECT_TRUE(torch::equal(a.clips.poses, b.clips.poses));
  const auto axis = GetParam() == LowPolyKind::Humanoid ? 1 : 0;
  EXPECT_NEAR(extent(a.model.v_template, axis), 17.0, 0.02);
  const auto seed0 = make_lowpoly_character(options(GetParam(), 0)), seed5 = make_lowpoly_character(options(GetParam(), 5));
  EXPECT_FALSE(torch::equal(seed0.model.v_template, seed5.model.v_template));
  testing::expect_error([&] {
    auto o = options(GetParam());
    o.size = -1;
    make_lowpoly_character(o);
  }, {"size"});
}

int run_cli(const std::string& arguments) {
  return std::system((std::string(FSKIN_CLI_PATH) + " " + arguments + " > /dev/null 2>&1").c_str());
}

TEST(LowPolyCharacterCommand, WritesTheModelAndItsClips) {
  const auto dir = testing::temp_dir("lowpoly_cli");
  const auto model = (dir / "fox.npz").string(), clips = (dir / "clips.npz").string();
  ASSERT_EQ(run_cli("character --kind lowpoly-animal --length 2.5 --seed 3 --out " + model + " --clips " + clips), 0);
  const auto loaded = BodyModel::load(model);
  EXPECT_NEAR(extent(loaded.data().v_template, 0), 2.5, 1e-3);
  const auto set = PoseSet::load(clips);
  EXPECT_EQ(set.clip_names, (std::vector<std::string>{"idle", "walk", "run"}));
  set.validate(clips, loaded.num_joints(), loaded.data().joint_names);
  // Flags of the other kinds are refused, not ignored.
  EXPECT_NE(run_cli("character --kind lowpoly-animal --clothed --out " + model), 0);
  EXPECT_NE(run_cli("character --kind lowpoly-animal --height 2 --out " + model), 0);
  EXPECT_NE(run_cli("character --kind humanoid --clips " + clips + " --out " + model), 0);
}

// The fox's ears and tail are thinner than the default grid's cells: a fresh
// run trains on the finer thin_part_grid_resolution grid, says so, and warns
// about the parts still thinner than its cells; thin_part_grid_resolution=0
// keeps the default grid (and schedule).
TEST(LowPolyCharacterCommand, TrainingRefinesTheGridForTheFoxsThinPartsAndWarnsAboutTheRest) {
  if (!inside_test_available()) GTEST_SKIP() << "built without Embree";
  const auto dir = testing::temp_dir("lowpoly_thin_warning");
  const auto path = [&](const std::string& name) { return (dir / name).string(); };
  ASSERT_EQ(run_cli("character --kind lowpoly-animal --out " + path("fox.npz") + " --clips " + path("clips.npz")), 0);
  ASSERT_EQ(run_cli("poses select " + path("clips.npz") + " --train walk:0-9 --out-train " + path("train.npz")), 0);
  ASSERT_EQ(run_cli("data build --model " + path("fox.npz") + " --poses " + path("train.npz") + " --out " +
                    path("data") + " --points 1000 --quiet"),
            0);
  const auto train = [&](const std::string& run, const std::string& extra) {
    const auto log = path(run + ".log");
    EXPECT_EQ(std::system((std::string(FSKIN_CLI_PATH) + " --threads 1 train --data " + path("data") + " --out " +
                           path(run) + " --steps 1 --quiet " + extra + " > " + log + " 2>&1")
                              .c_str()),
              0);
    std::ifstream in(log);
    return std::string((std::istreambuf_iterator<char>(in)), {});
  };
  const std::string refined = train("run", "");
  EXPECT_NE(refined.find("training with grid_resolution=48"), std::string::npos) << refined;
  EXPECT_NE(refined.find("thinner than the skinning grid's cells"), std::string::npos) << refined;
  EXPECT_NE(refined.find("ear"), std::string::npos) << refined;
  EXPECT_EQ(TrainConfig::load_run(path("run/config.json")).grid_resolution, 48);
  // ... and, with Fast-SNARF, the learning rate decaying over all the steps.
  EXPECT_NE(refined.find("decaying over the last 100 % of the steps"), std::string::npos) << refined;
  EXPECT_EQ(TrainConfig::load_run(path("run/config.json")).decay_fraction, 1.0);
  const std::string own_schedule = train("run_own_schedule", "--set thin_part_decay_fraction=-1");
  EXPECT_EQ(own_schedule.find("decaying over"), std::string::npos) << own_schedule;
  EXPECT_EQ(TrainConfig::load_run(path("run_own_schedule/config.json")).grid_resolution, 48);
  EXPECT_EQ(TrainConfig::load_run(path("run_own_schedule/config.json")).decay_fraction, 0.5);

  const std::string kept = train("run_kept", "--set thin_part_grid_resolution=0");
  EXPECT_EQ(kept.find("training with grid_resolution"), std::string::npos) << kept;
  EXPECT_NE(kept.find("(grid_resolution=32;"), std::string::npos) << kept;
  EXPECT_EQ(TrainConfig::load_run(path("run_kept/config.json")).grid_resolution, 32);
  EXPECT_EQ(TrainConfig::load_run(path("run_kept/config.json")).decay_fraction, 0.5);
}

INSTANTIATE_TEST_SUITE_P(Kinds, LowPoly, ::testing::Values(LowPolyKind::Humanoid, LowPolyKind::Animal),
                         [](const auto& info) { return info.param == LowPolyKind::Humanoid ? "Humanoid" : "Animal"; });

}  // namespace
}  // namespace fskin

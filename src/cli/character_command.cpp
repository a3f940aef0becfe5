// fskin character: generate a built-in procedural character (SMPL-format .npz):
// the humanoid (character.h), the quadruped (quadruped.h) or a game-style
// low-poly humanoid or animal with its animation clips (lowpoly_character.h).
#include "fskin/body/character.h"
#include "fskin/data/lowpoly_character.h"
#include "fskin/body/quadruped.h"
#include "fskin/data/pose_generators.h"

#include <torch/torch.h>

#include <cstdio>

#include "cli/commands.h"
#include "fskin/core/error.h"
#include "fskin/data/pose_set.h"
#include "fskin/geometry/mesh_topology.h"
#include "fskin/io/mesh_io.h"

namespace fskin::cli {
namespace {

// A handful of poses that show the rig and its correctives: T-pose, A-pose,
// bent elbows and knees, a walking step, arms raised. Axis-angle per joint;
// left is +x, so lowering the left arm is a negative rotation about z.
PoseSet demo_poses(const std::vector<std::string>& names) {
  const auto index = [&](const std::string& name) {
    return std::find(names.begin(), names.end(), name) - names.begin();
  };
  const int64_t J = static_cast<int64_t>(names.size());
  auto poses = torch::zeros({5, J, 3});
  const auto set = [&](int64_t frame, const std::string& joint, float x, float y, float z) {
    poses[frame][index(joint)] = torch::tensor({x, y, z});
  };
  for (int64_t frame : {1, 2, 3}) {  // arms down (A-pose)
    set(frame, "left_shoulder", 0, 0, -1.1f);
    set(frame, "right_shoulder", 0, 0, 1.1f);
  }
  set(2, "left_elbow", 0, -1.4f, 0);  // forearms forward
  set(2, "right_elbow", 0, 1.4f, 0);
  set(2, "left_hip", -0.9f, 0, 0);  // thighs forward, shins back: a squat
  set(2, "right_hip", -0.9f, 0, 0);
  set(2, "left_knee", 1.5f, 0, 0);
  set(2, "right_knee", 1.5f, 0, 0);
  set(3, "left_hip", -0.5f, 0, 0);  // walking step
  set(3, "right_hip", 0.3f, 0, 0);
  set(3, "right_knee", 0.6f, 0, 0);
  set(3, "left_knee", 0.2f, 0, 0);
  set(4, "left_shoulder", 0, 0, 1.0f);  // arms raised
  set(4, "right_shoulder", 0, 0, -1.0f);
  set(4, "left_elbow", 0, 0, 0.6f);
  set(4, "right_elbow", 0, 0, -0.6f);
  return PoseSet{poses, torch::zeros({5, 3}), names};
}

struct CharacterCommand {
  CharacterOptions character;
  QuadrupedOptions quadruped;
  std::string kind = "humanoid", out, mesh_out, poses_out, clips_out;
  int resolution = 0;  // 0: the kind's default
};

// What was written, its size and whether its surface is closed.
void print_summary(const CharacterCommand& opt, const BodyModel& model, const std::string& description) {
  const auto mesh = model.template_mesh();
  const auto topology = analyze_topology(mesh);
  const auto lo = std::get<0>(mesh.vertices.min(0)), hi = std::get<0>(mesh.vertices.max(0));
  std::printf("wrote %s: %s, seed %llu\n", opt.out.c_str(), description.c_str(),
              static_cast<unsigned long long>(opt.character.seed));
  std::printf("  %lld vertices, %lld faces, %lld joints, %lld shape directions\n",
              static_cast<long long>(model.num_vertices()), static_cast<long long>(mesh.num_faces()),
              static_cast<long long>(model.num_joints()), static_cast<long long>(model.num_betas()));
  std::printf("  closed manifold: %s, Euler characteristic %lld, components %lld\n",
              topology.is_closed_manifold() ? "yes" : "no", static_cast<long long>(topology.euler_characteristic()),
              static_cast<long long>(connected_components(mesh).count));
  std::printf("  bounding box: [%.3f, %.3f, %.3f] .. [%.3f, %.3f, %.3f] m\n", lo[0].item<float>(),
              lo[1].item<float>(), lo[2].item<float>(), hi[0].item<float>(), hi[1].item<float>(),
              hi[2].item<float>());
  if (!opt.mesh_out.empty()) {
    io::write_mesh(opt.mesh_out, mesh);
    std::printf("wrote %s\n", opt.mesh_out.c_str());
  }
}

void run_lowpoly(const CharacterCommand& opt, const CLI::App& cmd) {
  for (const char* flag : {"--clothed", "--resolution", "--girth", "--shoulder-width", "--hip-width", "--arm-length",
                           "--leg-length", "--head-size"})
    FSKIN_CHECK(cmd.count(flag) == 0, "fskin character: {} does not apply to --kind {}", flag, opt.kind);
  LowPolyOptions options;
  options.kind = parse_lowpoly_kind(opt.kind);
  options.seed = opt.character.seed;
  options.variation = opt.character.variation;
  const bool humanoid = options.kind == LowPolyKind::Humanoid;
  FSKIN_CHECK(cmd.count(humanoid ? "--length" : "--height") == 0, "fskin character: {} does not apply to --kind {}",
              humanoid ? "--length" : "--height", opt.kind);
  if (cmd.count("--height") > 0) options.size = opt.character.height;
  if (cmd.count("--length") > 0) options.size = opt.quadruped.length;
  const auto character = make_lowpoly_character(options);
  const BodyModel model(character.model, "built-in " + opt.kind);
  model.save(opt.out);
  print_summary(opt, model, "built-in " + opt.kind);
  const auto& clips = character.clips;
  std::string listing;
  for (size_t c = 0; c < clips.clip_names.size(); ++c) {
    const int64_t end = c + 1 < clips.clip_starts.size() ? clips.clip_starts[c + 1] : clips.size();
    listing += fmt::format("{}{} ({} frames)", c ? ", " : "", clips.clip_names[c], end - clips.clip_starts[c]);
  }
  std::printf("  clips: %s\n", listing.c_str());
  if (!opt.clips_out.empty()) {
    clips.save(opt.clips_out);
    std::printf("wrote %s (%lld poses in %zu clips)\n", opt.clips_out.c_str(), static_cast<long long>(clips.size()),
                clips.clip_names.size());
  }
  if (!opt.poses_out.empty()) {
    // Five frames spread over the clips.
    const auto index = torch::linspace(0, static_cast<double>(clips.size() - 1), 5).round().to(torch::kLong);
    PoseSet{clips.poses.index_select(0, index), clips.trans.index_select(0, index), clips.joint_names}.save(
        opt.poses_out);
    std::printf("wrote %s (5 demo poses from the clips)\n", opt.poses_out.c_str());
  }
}

}  // namespace

void register_character(CLI::App& app) {
  auto opt = std::make_shared<CharacterCommand>();
  auto& c = opt->character;
  auto* cmd = app.add_subcommand(
      "character", "Generate a built-in procedural character as an SMPL-format model (.npz)");
  cmd->add_option("--out", opt->out, "output model .npz")->required();
  cmd->add_option("--kind", opt->kind,
                  "humanoid (SMPL's 24 joints, T-pose), quadruped (33 joints: spine, neck, ears, four legs, "
                  "tail; standing), or a game-style low-poly character with painted weights, thin flat parts "
                  "and animation clips: lowpoly-humanoid (55 joints, fingers, ears, a cape; 1.8 m, facing +z) "
                  "or lowpoly-animal (a fox, 34 joints, thin ears, a flat tail; 0.9 m, facing +x)")
      ->check(CLI::IsMember({"humanoid", "quadruped", "lowpoly-humanoid", "lowpoly-animal"}))
      ->capture_default_str();
  cmd->add_flag("--clothed", c.clothed, "add a loose skirt (part of the closed surface)");
  cmd->add_option("--seed", c.seed, "seed of the proportions' variation")->capture_default_str();
  cmd->add_option("--resolution", opt->resolution,
                  "grid cells along the height (humanoid, default 110) or the length (quadruped, default 150)");
  cmd->add_option("--height", c.height, "humanoid, lowpoly-humanoid: height in metres (default 1.7, 1.8)");
  cmd->add_option("--length", opt->quadruped.length,
                  "quadruped, lowpoly-animal: nose to tail tip in metres (default 1.5, 0.9)");
  cmd->add_option("--girth", c.girth, "thickness multiplier")->capture_default_str();
  cmd->add_option("--shoulder-width", c.shoulder_width, "multiplier")->capture_default_str();
  cmd->add_option("--hip-width", c.hip_width, "multiplier")->capture_default_str();
  cmd->add_option("--arm-length", c.arm_length, "multiplier")->capture_default_str();
  cmd->add_option("--leg-length", c.leg_length, "multiplier")->capture_default_str();
  cmd->add_option("--head-size", c.head_size, "multiplier")->capture_default_str();
  cmd->add_option("--variation", c.variation, "relative size of the seed's variation")
      ->capture_default_str();
  const std::vector<std::string> humanoid_only = {"--clothed", "--height", "--girth", "--shoulder-width", "--hip-width",
                              "--arm-length", "--leg-length", "--head-size"};
  cmd->add_option("--mesh-out", opt->mesh_out, "also write the template mesh (.ply or .obj)");
  cmd->add_option("--write-poses", opt->poses_out,
                  "also write a few demo poses for this character (.npz pose file)");
  cmd->add_option("--clips", opt->clips_out,
                  "lowpoly kinds: also write the animation clips (.npz pose file with clip names, as `fskin "
                  "import --clips` writes; `fskin poses select` picks clips out of it)");
  cmd->callback([opt, cmd, humanoid_only] {
    if (opt->kind.rfind("lowpoly-", 0) == 0) {
      run_lowpoly(*opt, *cmd);
      return;
    }
    FSKIN_CHECK(opt->clips_out.empty(), "fskin character: --clips applies to the lowpoly kinds only");
    const bool quadruped = opt->kind == "quadruped";
    if (quadruped)
      for (const auto& flag : humanoid_only)
        FSKIN_CHECK(cmd->count(flag) == 0, "fskin character: {} applies to --kind humanoid only", flag);
    if (!quadruped && cmd->count("--length") > 0) fail("fskin character: --length applies to --kind quadruped only");
    opt->quadruped.seed = opt->character.seed;
    opt->quadruped.variation = opt->character.variation;
    if (opt->resolution > 0) (quadruped ? opt->quadruped.resolution : opt->character.resolution) = opt->resolution;
    const auto model = quadruped ? make_quadruped_model(opt->quadruped) : make_character_model(opt->character);
    model.save(opt->out);
    print_summary(*opt, model,
                  fmt::format("built-in {}{}, resolution {}", quadruped ? "quadruped" : "character",
                              opt->character.clothed ? " (clothed)" : "",
                              quadruped ? opt->quadruped.resolution : opt->character.resolution));
    if (!opt->poses_out.empty()) {
      const auto& names = model.data().joint_names;
      (quadruped ? make_ood_poses(names, {5, opt->quadruped.seed}) : demo_poses(names)).save(opt->poses_out);
      std::printf("wrote %s (5 demo poses)\n", opt->poses_out.c_str());
    }
  });
}

}  // namespace fskin::cli

// fskin avatar train | eval | render | mesh: textured avatars learned from
// image datasets (Fast-SNARF sec. 7; src/radiance).
#include <torch/torch.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>
#include <memory>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cli/commands.h"
#include "fskin/core/error.h"
#include "fskin/data/pose_set.h"
#include "fskin/export/image.h"
#include "fskin/io/mesh_io.h"
#include "fskin/radiance/avatar_evaluation.h"
#include "fskin/radiance/refined_poses.h"
#include "fskin/radiance/avatar_export.h"
#include "fskin/radiance/avatar_mesh.h"
#include "fskin/radiance/avatar_config.h"
#include "fskin/radiance/avatar_training.h"
#include "fskin/engine/stop_signal.h"
#include "fskin/gaussians/gaussian_config.h"
#include "fskin/gaussians/gaussian_evaluation.h"
#include "fskin/gaussians/gaussian_baking.h"
#include "fskin/gaussians/gaussian_export.h"
#include "fskin/gaussians/gaussian_training.h"
#include "fskin/util/atomic_file.h"
#include "fskin/util/progress.h"

namespace fskin::cli {
namespace {

namespace fs = std::filesystem;

Image to_image(const torch::Tensor& rgb) {
  const auto bytes = (rgb.clamp(0, 1) * 255).round().to(torch::kUInt8).contiguous();
  Image image(static_cast<int>(rgb.size(1)), static_cast<int>(rgb.size(0)));
  std::memcpy(image.rgb.data(), bytes.data_ptr<uint8_t>(), image.rgb.size());
  return image;
}

std::vector<int64_t> parse_indices(const std::string& text, int64_t count, const std::string& split) {
  std::vector<int64_t> out;
  std::stringstream stream(text);
  std::string item;
  while (std::getline(stream, item, ',')) {
    int64_t value = 0;
    try {
      size_t used = 0;
      value = std::stoll(item, &used);
      FSKIN_CHECK(used == item.size(), "--index: '{}' is not a number", item);
    } catch (const std::logic_error&) {
      fail("--index: '{}' is not a number", item);
    }
    FSKIN_CHECK(value >= 0 && value < count, "--index {} is out of range: split '{}' has {} images", value, split,
                count);
    out.push_back(value);
  }
  FSKIN_CHECK(!out.empty(), "--index: no image given");
  return out;
}

// What `avatar render` needs of a trained avatar, of either representation.
struct RenderableAvatar {
  std::string data_dir;  // the dataset it was trained on
  // rgb [H, W, 3] of bones with an appearance code (undefined: the mean appearance).
  std::function<torch::Tensor(const torch::Tensor& bones, const torch::Tensor& appearance, const PinholeCamera& camera,
                              const std::array<double, 3>& background)>
      render;
  // A split image's bones and code as the run learned them (refined poses, appearance codes).
  std::function<torch::Tensor(const torch::Tensor& given)> bones_for, appearance_for;
  // The posed body's centre (a turntable turns about it).
  std::function<Eigen::Vector3d(const torch::Tensor& bones)> centre;
};

// mesh: a Gaussian run drawn as the mesh `avatar export --mesh` writes.
RenderableAvatar load_renderable(const std::string& run, bool mesh) {
  RenderableAvatar out;
  FSKIN_CHECK(!mesh || is_gaussian_avatar_run(run),
              "{}: --mesh draws a Gaussian avatar's baked mesh; this is a volume avatar", run);
  if (is_gaussian_avatar_run(run)) {
    auto trained = std::make_shared<TrainedGaussianAvatar>(TrainedGaussianAvatar::load(run));
    out.data_dir = trained->options.data_dir;
    if (mesh) {
      const auto baked = std::make_shared<RiggedMesh>(
          baked_gaussian_mesh(*trained->avatar, ImageDataset(trained->options.data_dir).character()));
      out.render = [baked](const torch::Tensor& bones, const torch::Tensor&, const PinholeCamera& camera,
                           const std::array<double, 3>& background) {
        return render_baked_mesh(*baked, bones, camera, background);
      };
    } else {
      out.render = [trained](const torch::Tensor& bones, const torch::Tensor& appearance, const PinholeCamera& camera,
                             const std::array<double, 3>& background) {
        return trained->render(bones, camera, background, appearance).first;
      };
    }
    out.bones_for = [trained](const torch::Tensor& given) { return trained->bones_for(given); };
    // The baked mesh holds the colours at code zero (gaussian_baking.h).
    out.appearance_for = [trained, mesh](const torch::Tensor& given) {
      return mesh ? torch::Tensor() : trained->appearance_for(given);
    };
    out.centre = [trained](const torch::Tensor& bones) { return trained->avatar->centre(bones); };
    return out;
  }
  auto trained = std::make_shared<TrainedAvatar>(TrainedAvatar::load(run));
  out.data_dir = trained->options.data_dir;
  // Posing builds the frame's occupancy grid: a turntable poses once.
  auto posed = std::make_shared<std::pair<torch::Tensor, PosedFrame>>();
  out.render = [trained, posed](const torch::Tensor& bones, const torch::Tensor& appearance,
                                const PinholeCamera& camera, const std::array<double, 3>& background) {
    if (!posed->first.defined() || !torch::equal(posed->first, bones)) *posed = {bones, trained->avatar->pose(bones)};
    PosedFrame frame = posed->second;
    frame.appearance = appearance;
    return trained->avatar->render_image(frame, camera, background).first;
  };
  out.bones_for = [trained](const torch::Tensor& given) { return trained->bones_for(given); };
  out.appearance_for = [trained](const torch::Tensor& given) { return trained->appearance_for(given); };
  out.centre = [trained](const torch::Tensor& bones) {
    const auto frame = trained->avatar->pose(bones);
    const auto& g = frame.grid;
    return Eigen::Vector3d(0.5 * (g.lower[0] + g.upper[0]), 0.5 * (g.lower[1] + g.upper[1]),
                           0.5 * (g.lower[2] + g.upper[2]));
  };
  return out;
}

}  // namespace

void register_avatar(CLI::App& app) {
  auto* cmd = app.add_subcommand("avatar", "Textured avatars from images: train, evaluate, render, mesh");
  cmd->require_subcommand(1);

  // ---- train
  auto train = std::make_shared<AvatarTrainOptions>();
  auto quiet = std::make_shared<bool>(false);
  auto config_file = std::make_shared<std::string>();
  auto assignments = std::make_shared<std::vector<std::string>>();
  auto* t = cmd->add_subcommand("train", "Learn a canonical radiance field through the Fast-SNARF deformer from an "
                                         "image dataset (`fskin data images`); resumable, Ctrl-C saves a checkpoint");
  t->add_option("--data", train->data_dir, "image dataset directory")->required();
  t->add_option("--out", train->out_dir, "run directory")->required();
  t->add_option("--steps", train->steps, "training steps")->check(CLI::NonNegativeNumber);
  t->add_option("--rays", train->rays_per_step, "rays per step")->check(CLI::PositiveNumber);
  t->add_option("--images-per-step", train->images_per_step, "training images the rays of a step come from")
      ->check(CLI::PositiveNumber);
  t->add_option("--lr", train->learning_rate, "Adam learning rate")->check(CLI::PositiveNumber);
  t->add_option("--background", train->background, "background of the rendered rays")
      ->check(CLI::IsMember({"dataset", "white", "black", "random"}));
  t->add_option("--samples", train->avatar.samples_per_diagonal, "samples along the diagonal of the posed box");
  t->add_option("--levels", train->avatar.field.encoding.levels, "hash-encoding levels");
  t->add_option("--log2-table-size", train->avatar.field.encoding.log2_table_size, "hash-table rows per level (log2)");
  t->add_option("--checkpoint-every", train->checkpoint_every, "steps between checkpoints")->check(CLI::PositiveNumber);
  t->add_option("--seed", train->seed, "random seed");
  t->add_option("--shading", train->avatar.field.shading,
                 "none: one colour per canonical point; lambert (volume): that colour shaded by a learned distant "
                 "light through the posed surface; irradiance (gaussians): shaded by learned distant lighting of "
                 "the posed normal (captures under fixed lights)")
      ->check(CLI::IsMember({"none", "lambert", "irradiance"}));
  t->add_option("--appearance-codes", train->avatar.field.appearance_dim,
                "length of a learned code per training frame that the colour is conditioned on (light that "
                "changes from frame to frame; new poses get the codes' mean); 0: none (with --representation "
                "gaussians: model.appearance.dim)")
      ->check(CLI::NonNegativeNumber);
  t->add_flag(
      "--learn-skinning", [train](int64_t) { train->avatar.skinning = "learned"; },
      "learn the skinning weights through the renderer, from the character's (clothing, hair; "
      "losses.skinning_prior.weight keeps them near)");
  t->add_flag("--refine-poses", train->refine_poses,
              "learn a correction of every training pose with the avatar (noisy captured poses; "
              "pose_refinement.* in the config)");
  t->add_option("--config", *config_file,
                 "JSON config overlaid on the options (nested per component; `fskin config show RUN` prints one)");
  t->add_option("--set", *assignments, "config override a.b.c=value after --config (repeatable), e.g. "
                                       "model.occupancy_grid.every=50");
  t->add_flag("--resume", train->resume, "continue the run in --out from its newest checkpoint");
  t->add_flag("--quiet", *quiet, "no progress bar");
  auto representation = std::make_shared<std::string>("volume");
  t->add_option("--representation", *representation,
                "volume: a radiance field through the Fast-SNARF deformer (Fast-SNARF sec. 7); gaussians: "
                "articulated 3-D Gaussians posed by forward skinning (--config / --set take the Gaussian "
                "avatar's document, docs/gaussian_avatars.md)")
      ->check(CLI::IsMember({"volume", "gaussians"}));
  t->callback([t, train, quiet, config_file, assignments, representation] {
    StopSignal stop;
    if (*representation == "gaussians") {
      // The volume avatar's own options do not apply.
      for (const char* name : {"--rays", "--images-per-step", "--lr", "--background", "--samples", "--levels",
                               "--log2-table-size", "--learn-skinning"}) {
        FSKIN_CHECK(t->count(name) == 0, "{} is an option of the volume avatar, not of --representation gaussians",
                    name);
      }
      GaussianTrainOptions base;
      base.data_dir = train->data_dir;
      base.out_dir = train->out_dir;
      base.seed = train->seed;
      if (t->count("--steps") > 0) base.steps = train->steps;
      if (t->count("--checkpoint-every") > 0) base.checkpoint_every = train->checkpoint_every;
      if (t->count("--refine-poses") > 0) base.refine_poses = true;
      if (t->count("--shading") > 0) base.avatar.shading = train->avatar.field.shading;
      if (t->count("--appearance-codes") > 0) base.avatar.appearance.dim = train->avatar.field.appearance_dim;
      GaussianTrainOptions options = configure_gaussian_options(base, *config_file, *assignments);
      options.resume = train->resume;
      options.progress = !*quiet;
      options.stop = &stop;
      const auto summary = train_gaussian_avatar(options);
      if (summary.pose_pass_last_step > summary.pose_pass_first_step)
        std::printf("%s: first pass of pose refinement: steps %lld -> %lld\n", options.out_dir.c_str(),
                    static_cast<long long>(summary.pose_pass_first_step),
                    static_cast<long long>(summary.pose_pass_last_step));
      std::printf("%s: steps %lld -> %lld in %.1f s; %lld Gaussians; last loss %.5f, image PSNR %.2f dB%s\n",
                  options.out_dir.c_str(), static_cast<long long>(summary.first_step),
                  static_cast<long long>(summary.last_step), summary.seconds, static_cast<long long>(summary.gaussians),
                  summary.final_loss, summary.final_psnr, summary.stopped ? " (stopped; --resume continues)" : "");
      return;
    }
    AvatarTrainOptions options = configure_avatar_options(*train, *config_file, *assignments);
    options.progress = !*quiet;
    options.stop = &stop;
    // Launched as one of several ranks (torchrun's variables): data-parallel.
    const auto parallel = join_launch_group();
    options.parallel = parallel.get();
    const auto summary = train_avatar(options);
    if (parallel && parallel->rank() != 0) return;
    std::printf("%s: steps %lld -> %lld in %.1f s; last loss %.5f, batch PSNR %.2f dB%s\n", options.out_dir.c_str(),
                static_cast<long long>(summary.first_step), static_cast<long long>(summary.last_step), summary.seconds,
                summary.final_loss, summary.final_psnr, summary.stopped ? " (stopped; --resume continues)" : "");
  });

  // ---- eval
  struct EvalOptions {
    std::string run, data, split = "novel_view", json;
    int64_t max_images = 0, fit_poses = 0, subdivisions = -1;
    bool quiet = false, mesh = false;
  };
  auto eval = std::make_shared<EvalOptions>();
  auto* e = cmd->add_subcommand("eval", "PSNR and SSIM of the avatar's renders against a split of its dataset");
  e->add_option("run", eval->run, "avatar run directory")->required();
  e->add_option("--data", eval->data, "image dataset (default: the one the run was trained on)");
  e->add_option("--split", eval->split, "split to render")->check(CLI::IsMember({"train", "novel_view", "novel_pose"}));
  e->add_option("--max-images", eval->max_images, "evaluate at most this many images, evenly spread (0: all)")
      ->check(CLI::NonNegativeNumber);
  e->add_option("--json", eval->json, "write the scores per image to this JSON file");
  e->add_option("--fit-poses", eval->fit_poses,
                 "fit each image's pose to it first with this many steps (test-time pose optimisation, the avatar "
                 "frozen; scores then measure the avatar given the best pose per image)")
      ->check(CLI::NonNegativeNumber);
  e->add_flag("--mesh", eval->mesh,
              "a Gaussian avatar: score the mesh `avatar export --mesh` writes (the Gaussians' colours baked into the "
              "character's subdivided mesh) instead of the Gaussians");
  e->add_option("--subdivisions", eval->subdivisions, "with --mesh: as avatar export's")
      ->check(CLI::Range(int64_t{-1}, int64_t{4}));
  e->add_flag("--quiet", eval->quiet, "no progress bar");
  e->callback([e, eval] {
    PoseFittingOptions fitting;
    fitting.steps = eval->fit_poses;
    const bool gaussians = is_gaussian_avatar_run(eval->run);
    FSKIN_CHECK(eval->mesh || e->count("--subdivisions") == 0, "--subdivisions applies with --mesh");
    FSKIN_CHECK(!eval->mesh || gaussians, "{}: --mesh scores a Gaussian avatar's baked mesh; this is a volume avatar",
                eval->run);
    FSKIN_CHECK(!eval->mesh || eval->fit_poses == 0, "--fit-poses fits the Gaussians' poses; it does not apply with --mesh");
    AvatarEvaluation scores;
    if (eval->mesh) {
      GaussianBakingOptions baking;
      baking.subdivisions = eval->subdivisions;
      scores = evaluate_baked_gaussian_mesh(eval->run, eval->data, eval->split, eval->max_images, !eval->quiet, baking);
    } else {
      scores = gaussians
                   ? evaluate_gaussian_avatar_run(eval->run, eval->data, eval->split, eval->max_images, !eval->quiet,
                                                  fitting)
                   : evaluate_avatar_run(eval->run, eval->data, eval->split, eval->max_images, !eval->quiet, fitting);
    }
    std::printf("%s", scores.to_table().c_str());
    const std::string json =
        eval->json.empty()
            ? (fs::path(eval->run) / fmt::format(eval->mesh ? "eval_mesh_{}.json" : "eval_{}.json", eval->split)).string()
            : eval->json;
    write_file_atomically(json, scores.to_json());
    std::printf("wrote %s\n", json.c_str());
  });

  // ---- poses
  struct PosesOptions {
    std::string run, out;
  };
  auto poses = std::make_shared<PosesOptions>();
  auto* p = cmd->add_subcommand("poses", "The training poses a run refined (--refine-poses): the correction, the "
                                         "error against exact poses when the dataset keeps them, an .npz");
  p->add_option("run", poses->run, "avatar run directory")->required();
  p->add_option("--out", poses->out, "write given, refined (and exact) bone transforms to this .npz");
  p->callback([poses] {
    const auto refined =
        is_gaussian_avatar_run(poses->run) ? refined_gaussian_poses(poses->run) : refined_poses(poses->run);
    std::printf("%s\n", refined.to_string().c_str());
    if (!poses->out.empty()) {
      refined.save(poses->out);
      std::printf("wrote %s\n", poses->out.c_str());
    }
  });

  // ---- render
  struct RenderOptions {
    std::string run, data, split = "novel_pose", index = "0", out, poses, bones, model, cameras;
    int64_t pose_index = 0, camera_index = 0;
    bool compare = false, animation = false, mesh = false;
    int turntable = 0;
  };
  auto render = std::make_shared<RenderOptions>();
  auto* r = cmd->add_subcommand("render", "Render the avatar in the pose and from the camera of dataset images");
  r->add_option("run", render->run, "avatar run directory")->required();
  r->add_option("--data", render->data, "image dataset (default: the run's)");
  r->add_option("--split", render->split, "split of the pose and camera")
      ->check(CLI::IsMember({"train", "novel_view", "novel_pose"}));
  r->add_option("--index", render->index, "image index in the split, or several separated by commas (one row each)");
  r->add_flag("--compare", render->compare, "put the ground truth to the left of each render");
  r->add_option("--turntable", render->turntable,
                "instead: this many frames of the first index's pose, the camera turning once about +Y, "
                "written as PNGs into --out (a directory)")
      ->check(CLI::Range(1, 3600));
  r->add_option("--poses", render->poses,
                "instead of the split's pose: a pose file (.npz) posed with the dataset's body model")
      ->check(CLI::ExistingFile);
  r->add_option("--bones", render->bones,
                "instead of the split's pose: bone transforms (canonical -> posed) of the run's character, an .npz "
                "with bone_transforms [N, J, 4, 4] as a split's poses.npz holds them; any rig, no body model")
      ->check(CLI::ExistingFile);
  r->add_option("--pose-index", render->pose_index, "pose of --poses or --bones")->check(CLI::NonNegativeNumber);
  r->add_flag("--animation", render->animation,
              "every pose of --poses or --bones, from the first index's camera, as PNG frames into --out (a "
              "directory)");
  r->add_option("--model", render->model, "body model for --poses (default: the one the dataset's manifest records)");
  r->add_option("--cameras", render->cameras, "instead of the split's camera: a cameras.npz (OpenCV convention)")
      ->check(CLI::ExistingFile);
  r->add_option("--camera-index", render->camera_index, "camera of --cameras")->check(CLI::NonNegativeNumber);
  r->add_flag("--mesh", render->mesh,
              "a Gaussian avatar drawn as the mesh `avatar export --mesh` writes (its colours baked into the "
              "character's subdivided mesh)");
  r->add_option("--out", render->out, "PNG file (or directory with --turntable)")->required();
  r->callback([render] {
    const auto avatar = load_renderable(render->run, render->mesh);
    const ImageDataset data(render->data.empty() ? avatar.data_dir : render->data);
    const auto split = data.load_split(render->split);
    const auto indices = parse_indices(render->index, split.size(), render->split);
    // The split's poses as the run learned them: a training frame's refined
    // bones and appearance code (the mean appearance for other poses).
    auto bones = split.bone_transforms.clone();
    std::vector<torch::Tensor> appearance(static_cast<size_t>(split.size()));
    for (const int64_t i : indices) {
      bones[i] = avatar.bones_for(split.bone_transforms[i]);
      appearance[i] = avatar.appearance_for(split.bone_transforms[i]);
    }
    auto cameras = split.cameras;
    FSKIN_CHECK(render->poses.empty() || render->bones.empty(), "give --poses or --bones, not both");
    FSKIN_CHECK(!render->animation || !render->poses.empty() || !render->bones.empty(),
                "--animation renders the poses of --poses or --bones: give one");
    FSKIN_CHECK(!render->animation || render->turntable == 0, "give --animation or --turntable, not both");
    torch::Tensor given_bones;  // [K, J, 4, 4] instead of the split's
    std::string given_path;
    if (!render->poses.empty()) {
      given_path = render->poses;
      given_bones = data.bone_transforms(PoseSet::load(render->poses), render->poses, render->model);
    } else if (!render->bones.empty()) {
      given_path = render->bones;
      given_bones = load_bone_transforms(render->bones, data.character().num_joints());
    }
    if (given_bones.defined()) {
      FSKIN_CHECK(!render->compare, "--compare needs the split's own poses (there is no ground truth for {})",
                  given_path);
      FSKIN_CHECK(given_bones.size(0) > 0, "{}: holds no poses", given_path);
      FSKIN_CHECK(render->pose_index < given_bones.size(0), "--pose-index {} is out of range: {} has {} poses",
                  render->pose_index, given_path, given_bones.size(0));
      for (const int64_t i : indices) {
        bones[i] = given_bones[render->pose_index];
        appearance[i] = torch::Tensor();
      }
    }
    if (!render->cameras.empty()) {
      FSKIN_CHECK(!render->compare, "--compare needs the split's own cameras (there is no ground truth for --cameras)");
      const auto given = load_cameras(render->cameras, -1);
      FSKIN_CHECK(render->camera_index < static_cast<int64_t>(given.size()),
                  "--camera-index {} is out of range: {} has {} cameras", render->camera_index, render->cameras,
                  given.size());
      for (const int64_t i : indices) cameras[i] = given[render->camera_index];
    }
    if (render->animation) {
      create_output_directory(render->out);
      const auto& camera = cameras[indices[0]];
      ProgressBar bar("rendering " + given_path, given_bones.size(0), true);
      for (int64_t k = 0; k < given_bones.size(0); ++k) {
        const auto rgb = avatar.render(given_bones[k], torch::Tensor(), camera, data.background());
        write_png((fs::path(render->out) / fmt::format("frame_{:04d}.png", k)).string(), to_image(rgb));
        bar.advance(1);
      }
      bar.finish();
      std::printf("wrote %lld frames to %s\n", static_cast<long long>(given_bones.size(0)), render->out.c_str());
      return;
    }
    if (render->turntable > 0) {
      const int64_t i = indices[0];
      create_output_directory(render->out);
      // Turn the camera about the vertical axis through the posed body's centre.
      const Eigen::Vector3d centre = avatar.centre(bones[i]);
      for (int k = 0; k < render->turntable; ++k) {
        const auto camera = cameras[i].orbited(2 * M_PI * k / render->turntable, centre);
        const auto rgb = avatar.render(bones[i], appearance[i], camera, data.background());
        write_png((fs::path(render->out) / fmt::format("frame_{:04d}.png", k)).string(), to_image(rgb));
      }
      std::printf("wrote %d frames to %s\n", render->turntable, render->out.c_str());
      return;
    }
    const int W = cameras[indices[0]].width, H = cameras[indices[0]].height;
    const int columns = render->compare ? 2 : 1;
    Image sheet(W * columns, H * static_cast<int>(indices.size()));
    for (size_t row = 0; row < indices.size(); ++row) {
      const int64_t i = indices[row];
      FSKIN_CHECK(cameras[i].width == W && cameras[i].height == H, "images of one sheet must have one size");
      const auto rgb = avatar.render(bones[i], appearance[i], cameras[i], data.background());
      if (render->compare) sheet.paste(to_image(split.images[i].to(torch::kFloat32) / 255), 0, static_cast<int>(row) * H);
      sheet.paste(to_image(rgb), (columns - 1) * W, static_cast<int>(row) * H);
    }
    write_png(render->out, sheet);
    std::printf("wrote %s\n", render->out.c_str());
  });

  // ---- export
  struct ExportOptions {
    std::string run, data, split, bones, out;
    int64_t resolution = 128, influences = 4, subdivisions = -1;
    double fps = 30;
    bool mesh = false;
  };
  auto exported = std::make_shared<ExportOptions>();
  auto* x = cmd->add_subcommand("export", "The avatar as a rigged glTF character (.glb/.gltf): its coloured surface "
                                          "with the skinning weights it is posed with, the dataset's skeleton, and "
                                          "optionally an animation; a Gaussian avatar as a 3DGS .ply or a glTF "
                                          "with KHR_gaussian_splatting, with its weights, skeleton and animation");
  x->add_option("run", exported->run, "avatar run directory")->required();
  x->add_option("--out", exported->out, "output .glb or .gltf (a Gaussian avatar: also .ply)")->required();
  x->add_option("--resolution", exported->resolution, "grid samples along the canonical box's longest side")
      ->check(CLI::Range(int64_t{8}, int64_t{1024}));
  x->add_option("--data", exported->data, "image dataset (default: the run's)");
  x->add_option("--split", exported->split, "animate with the bone transforms of this split's images")
      ->check(CLI::IsMember({"train", "novel_view", "novel_pose"}));
  x->add_option("--bones", exported->bones, "animate with these bone transforms (.npz, bone_transforms [N, J, 4, 4])")
      ->check(CLI::ExistingFile);
  x->add_option("--fps", exported->fps, "frames per second of the animation")->check(CLI::PositiveNumber);
  x->add_option("--influences", exported->influences,
                "largest weights kept per vertex or Gaussian (4: what every engine reads; 0: all)")
      ->check(CLI::NonNegativeNumber);
  x->add_flag("--mesh", exported->mesh,
              "a Gaussian avatar as a rigged mesh (.glb/.gltf) for engines that draw no Gaussians: the character's "
              "mesh, subdivided, with the Gaussians' colours baked into its vertices");
  x->add_option("--subdivisions", exported->subdivisions,
                "with --mesh: midpoint subdivisions of the character's mesh (-1: the fewest that give at least as "
                "many vertices as Gaussians)")
      ->check(CLI::Range(int64_t{-1}, int64_t{4}));
  x->callback([x, exported] {
    FSKIN_CHECK(exported->split.empty() || exported->bones.empty(), "give --split or --bones, not both");
    const auto extension = fs::path(exported->out).extension().string();
    FSKIN_CHECK(exported->mesh || x->count("--subdivisions") == 0, "--subdivisions applies with --mesh");
    FSKIN_CHECK(!exported->mesh || is_gaussian_avatar_run(exported->run),
                "{}: --mesh bakes a Gaussian avatar into a mesh; a volume avatar's export is a mesh already",
                exported->run);
    if (is_gaussian_avatar_run(exported->run)) {
      // The Gaussians themselves: 3DGS's PLY layout plus weights, skeleton and animation, or a skinned
      // glTF with the Khronos Gaussian-splatting extension; with --mesh, the character's mesh with
      // their colours baked into its vertices, a skinned glTF.
      FSKIN_CHECK(x->count("--resolution") == 0, "--resolution applies to the volume avatar's surface, not to Gaussians");
      FSKIN_CHECK(exported->mesh || extension != ".ply" || x->count("--influences") == 0,
                  "--influences applies to glTF; the .ply keeps every joint's weight");
      auto trained = TrainedGaussianAvatar::load(exported->run);
      const ImageDataset data(exported->data.empty() ? trained.options.data_dir : exported->data);
      GaussianExportOptions file;
      if (!exported->split.empty()) file.bones = data.load_split(exported->split).bone_transforms;
      if (!exported->bones.empty()) file.bones = load_bone_transforms(exported->bones, data.character().num_joints());
      file.fps = exported->fps;
      file.influences = exported->influences;
      const auto gaussians = static_cast<long long>(trained.avatar->size());
      std::string written;
      if (exported->mesh) {
        GaussianBakingOptions baking;
        baking.subdivisions = exported->subdivisions;
        const auto vertices = write_gaussian_mesh_file(exported->out, *trained.avatar, data.character(), file, baking);
        written = fmt::format("{} vertices with colours baked from {} Gaussians", vertices, gaussians);
      } else {
        write_gaussian_avatar_file(exported->out, *trained.avatar, data.character().skeleton, file);
        written = fmt::format("{} Gaussians", gaussians);
      }
      if (trained.avatar->options().non_rigid) {
        std::printf("note: the avatar's non-rigid offsets depend on the pose and are not in the file: players "
                    "pose it by skinning alone\n");
      }
      if (trained.avatar->shading()) {
        std::printf("note: the avatar's learned lighting is not in the file: its colours are the albedo, for the "
                    "player's own lights to shade\n");
      }
      const auto& bones = file.bones;
      std::printf("wrote %s (%s, %lld joints%s)\n", exported->out.c_str(), written.c_str(),
                  static_cast<long long>(data.character().num_joints()),
                  bones.defined() ? fmt::format(", an animation of {} poses", bones.size(0)).c_str() : "");
      return;
    }
    FSKIN_CHECK(extension == ".glb" || extension == ".gltf", "{}: the avatar is written as glTF: name it .glb or .gltf",
                exported->out);
    auto trained = TrainedAvatar::load(exported->run);
    const ImageDataset data(exported->data.empty() ? trained.options.data_dir : exported->data);
    torch::Tensor bones;
    if (!exported->split.empty()) bones = data.load_split(exported->split).bone_transforms;
    if (!exported->bones.empty()) bones = load_bone_transforms(exported->bones, data.character().num_joints());
    auto character = rigged_image_avatar(trained.avatar, data.character().skeleton, exported->resolution, bones,
                                         exported->fps);
    character.influences = exported->influences;
    write_skinned_gltf(exported->out, character);
    std::printf("wrote %s (%lld vertices with colours, %lld joints%s)\n", exported->out.c_str(),
                static_cast<long long>(character.mesh.num_vertices()),
                static_cast<long long>(character.skeleton.num_joints()),
                bones.defined() ? fmt::format(", an animation of {} poses", bones.size(0)).c_str() : "");
  });

  // ---- mesh
  struct MeshOptions {
    std::string run, data, split, out;
    int64_t index = 0, resolution = 128;
  };
  auto mesh = std::make_shared<MeshOptions>();
  auto* m = cmd->add_subcommand("mesh", "The avatar's surface (density level set) with vertex colours, canonical or "
                                        "posed like a dataset image (PLY/OBJ)");
  m->add_option("run", mesh->run, "avatar run directory")->required();
  m->add_option("--resolution", mesh->resolution, "grid samples along the canonical box's longest side")
      ->check(CLI::Range(int64_t{8}, int64_t{1024}));
  m->add_option("--data", mesh->data, "image dataset (default: the run's), for --split");
  m->add_option("--split", mesh->split, "pose the mesh like this split's image --index (default: canonical)")
      ->check(CLI::IsMember({"train", "novel_view", "novel_pose"}));
  m->add_option("--index", mesh->index, "image index in --split")->check(CLI::NonNegativeNumber);
  m->add_option("--out", mesh->out, "mesh file (.ply keeps the colours)")->required();
  m->callback([mesh] {
    auto trained = TrainedAvatar::load(mesh->run);
    torch::Tensor bones;
    if (!mesh->split.empty()) {
      const ImageDataset data(mesh->data.empty() ? trained.options.data_dir : mesh->data);
      const auto split = data.load_split(mesh->split);
      FSKIN_CHECK(mesh->index < split.size(), "--index {} is out of range: split '{}' has {} images", mesh->index,
                  mesh->split, split.size());
      bones = split.bone_transforms[mesh->index];
    }
    const Mesh surface = avatar_mesh(trained.avatar, mesh->resolution, bones);
    io::write_mesh(mesh->out, surface);
    std::printf("wrote %s (%lld vertices, %lld faces)\n", mesh->out.c_str(),
                static_cast<long long>(surface.num_vertices()), static_cast<long long>(surface.num_faces()));
  });
}

}  // namespace fskin::cli

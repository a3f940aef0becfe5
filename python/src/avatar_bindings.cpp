// Image datasets and avatars from images, as `fskin data images` and `fskin avatar`.
#include "bindings.h"

#include <array>

#include "fskin/export/image.h"
#include "fskin/export/skinned_gltf.h"
#include "fskin/gaussians/gaussian_baking.h"
#include "fskin/gaussians/gaussian_config.h"
#include "fskin/gaussians/gaussian_evaluation.h"
#include "fskin/gaussians/gaussian_export.h"
#include "fskin/gaussians/gaussian_training.h"
#include "fskin/radiance/avatar_export.h"
#include "fskin/radiance/capture_import.h"

#include "fskin/body/body_model.h"
#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/data/pose_set.h"
#include "fskin/radiance/avatar_config.h"
#include "fskin/radiance/avatar_evaluation.h"
#include "fskin/radiance/avatar_training.h"
#include "fskin/radiance/pose_perturbation.h"
#include "fskin/radiance/refined_poses.h"
#include "fskin/radiance/image_dataset.h"
#include "fskin/radiance/image_dataset_builder.h"
#include "fskin/util/blas_threads.h"

namespace fskin::python {

void bind_avatars(py::module_& m) {
  m.def(
      "read_png",
      [](const std::string& path) {
        fskin::Image image;
        {
          py::gil_scoped_release release;
          image = fskin::read_png(path);
        }
        return torch::from_blob(image.rgb.data(), {image.height, image.width, 3}, torch::kUInt8).clone();
      },
      py::arg("path"),
      "An 8-bit PNG (grey, grey + alpha, RGB or RGBA) as RGB uint8 [H, W, 3], alpha dropped (a dataset's "
      "images and masks)");
  m.def(
      "write_png",
      [](const std::string& path, const torch::Tensor& image) {
        FSKIN_CHECK(image.dim() == 3 && image.size(2) == 3 && image.scalar_type() == torch::kUInt8,
                    "write_png: {}: need an RGB uint8 tensor [H, W, 3], got {} of {}", path,
                    shape_string(image.sizes()), c10::toString(image.scalar_type()));
        FSKIN_CHECK(image.size(0) > 0 && image.size(1) > 0 && image.size(0) <= kMaxImageSide &&
                        image.size(1) <= kMaxImageSide,
                    "write_png: {}: a {} x {} picture; need 1..{} pixels a side", path, image.size(1),
                    image.size(0), kMaxImageSide);
        const auto pixels = image.contiguous().cpu();
        fskin::Image out(static_cast<int>(pixels.size(1)), static_cast<int>(pixels.size(0)));
        std::copy(pixels.data_ptr<uint8_t>(), pixels.data_ptr<uint8_t>() + pixels.numel(), out.rgb.begin());
        py::gil_scoped_release release;
        fskin::write_png(path, out);
      },
      py::arg("path"), py::arg("image"),
      "Write an RGB uint8 [H, W, 3] tensor as an 8-bit PNG (atomically), as read_png reads it");
  m.def(
      "build_image_dataset",
      [](const std::string& model_path, const torch::Tensor& poses, const std::string& out,
         const std::optional<torch::Tensor>& held_out_poses, int size, int width, int height, int views,
         int held_out_views, int novel_view_frames, bool monocular, int supersampling,
         const std::string& canonical_pose, const std::array<double, 3>& background,
         const std::array<double, 3>& light, double ambient, bool progress) {
        const auto model = BodyModel::load(model_path);
        const auto& names = model.data().joint_names;
        fskin::ImageDatasetOptions options;
        options.out_dir = out;
        options.width = size > 0 ? size : width;
        options.height = size > 0 ? size : height;
        options.training_views = views;
        options.held_out_views = held_out_views;
        options.novel_view_frames = novel_view_frames;
        options.monocular = monocular;
        options.supersampling = supersampling;
        options.canonical_pose = canonical_pose;
        options.background = background;
        options.light = light;
        options.ambient = ambient;
        options.progress = progress;
        options.model_source = std::filesystem::absolute(model_path).string();
        options.poses_source = "python";
        options.ood_poses_source = held_out_poses ? "python" : "";
        const auto train = pose_set(poses, std::nullopt, names, "build_image_dataset: poses");
        const auto held_out = held_out_poses
                                  ? pose_set(*held_out_poses, std::nullopt, names, "build_image_dataset: held_out_poses")
                                  : fskin::PoseSet{};
        py::gil_scoped_release release;
        return fskin::build_image_dataset(model, train, held_out, options).to_string();
      },
      py::arg("model"), py::arg("poses"), py::arg("out"), py::arg("held_out_poses") = py::none(),
      py::arg("size") = 0, py::arg("width") = fskin::ImageDatasetOptions{}.width,
      py::arg("height") = fskin::ImageDatasetOptions{}.height,
      py::arg("views") = fskin::ImageDatasetOptions{}.training_views,
      py::arg("held_out_views") = fskin::ImageDatasetOptions{}.held_out_views,
      py::arg("novel_view_frames") = fskin::ImageDatasetOptions{}.novel_view_frames, py::arg("monocular") = false,
      py::arg("supersampling") = fskin::ImageDatasetOptions{}.supersampling, py::arg("canonical_pose") = "default",
      // A tuple, so that the signature's default matches its Tuple type (the stubs, mypy).
      py::arg("background") = py::make_tuple(fskin::ImageDatasetOptions{}.background[0],
                                              fskin::ImageDatasetOptions{}.background[1],
                                              fskin::ImageDatasetOptions{}.background[2]),
      py::arg("light") = py::make_tuple(0.0, 0.0, 0.0), py::arg("ambient") = fskin::ImageDatasetOptions{}.ambient,
      py::arg("progress") = false,
      "An image dataset as `fskin data images` writes it (PeopleSnapshot's layout), from a model file and poses "
      "[N, J, 3]; size (> 0) sets width and height; returns its summary");
  m.def(
      "import_capture",
      [](const std::string& capture, const std::string& model, const std::string& out, const std::string& train,
         const std::string& novel_pose, const std::string& train_poses, const std::string& novel_pose_poses,
         const std::array<double, 3>& background, const std::string& canonical_pose, bool progress) {
        fskin::CaptureImportOptions options;
        options.capture_dir = capture;
        options.model_path = model;
        options.out_dir = out;
        options.train = train;
        options.novel_pose = novel_pose;
        options.train_poses = train_poses;
        options.novel_pose_poses = novel_pose_poses;
        options.background = background;
        options.canonical_pose = canonical_pose;
        options.progress = progress;
        py::gil_scoped_release release;
        return fskin::import_capture(options).to_string();
      },
      py::arg("capture"), py::arg("model"), py::arg("out"), py::arg("train") = "0:", py::arg("novel_pose") = "",
      py::arg("train_poses") = "", py::arg("novel_pose_poses") = "", py::arg("background") = py::make_tuple(1.0, 1.0, 1.0), py::arg("canonical_pose") = "default",
      py::arg("progress") = false,
      "`fskin data capture`: a capture in InstantAvatar's PeopleSnapshot layout (cameras.npz, images/, masks/*.npy "
      "or .png, poses.npz with SMPL parameters) as an image dataset, posed with your SMPL-family model; frame "
      "ranges 'start:stop:step'; returns its summary");
  m.def(
      "perturb_poses",
      [](const std::string& data, const std::string& out, double degrees, double translation, uint64_t seed) {
        fskin::PosePerturbationOptions options;
        options.data_dir = data;
        options.out_dir = out;
        options.degrees = degrees;
        options.translation = translation;
        options.seed = seed;
        py::gil_scoped_release release;
        return fskin::perturb_image_dataset_poses(options).to_string();
      },
      py::arg("data"), py::arg("out"), py::arg("degrees") = 5.0, py::arg("translation") = 0.01, py::arg("seed") = 0,
      "`fskin data perturb-poses`: a copy of an image dataset with noise on its train and novel_view poses (degrees "
      "per joint, a root shift as a fraction of the character's size); the exact poses stay in each poses.npz as "
      "bone_transforms_exact; returns its summary");
  m.def(
      "refined_poses",
      [](const std::string& run) {
        fskin::RefinedPoses refined;
        {
          py::gil_scoped_release release;
          refined = fskin::is_gaussian_avatar_run(run) ? fskin::refined_gaussian_poses(run) : fskin::refined_poses(run);
        }
        py::dict out;
        out["given"] = refined.given;
        out["refined"] = refined.refined;
        out["exact"] = refined.exact.defined() ? py::cast(refined.exact) : py::none();
        out["summary"] = refined.to_string();
        return out;
      },
      py::arg("run"),
      "`fskin avatar poses`: the training poses a run refined (trained with settings "
      "['pose_refinement.enabled=true']): a dict of bone transforms [F, J, 4, 4] 'given', 'refined', 'exact' (None "
      "unless the dataset keeps them) and 'summary'");
  m.def(
      "export_avatar",
      [](const std::string& run, const std::string& out, const std::optional<torch::Tensor>& bones, int64_t resolution,
         double fps, int64_t influences, const std::string& data, bool mesh, int64_t subdivisions) {
        py::gil_scoped_release release;
        const auto given = bones ? bones->detach().to(torch::kCPU, torch::kFloat32) : torch::Tensor();
        const bool gaussians = fskin::is_gaussian_avatar_run(run);
        FSKIN_CHECK(!mesh || gaussians,
                    "{}: mesh=True bakes a Gaussian avatar into a mesh; a volume avatar's export is a mesh already", run);
        if (gaussians) {  // .ply or glTF by extension (docs/gaussian_avatars.md)
          auto trained = fskin::TrainedGaussianAvatar::load(run);
          const fskin::ImageDataset dataset(data.empty() ? trained.options.data_dir : data);
          fskin::GaussianExportOptions file;
          file.bones = given;
          file.fps = fps;
          file.influences = influences;
          if (mesh) {
            fskin::GaussianBakingOptions baking;
            baking.subdivisions = subdivisions;
            fskin::write_gaussian_mesh_file(out, *trained.avatar, dataset.character(), file, baking);
          } else {
            fskin::write_gaussian_avatar_file(out, *trained.avatar, dataset.character().skeleton, file);
          }
          return;
        }
        auto trained = fskin::TrainedAvatar::load(run);
        const fskin::ImageDataset dataset(data.empty() ? trained.options.data_dir : data);
        auto character = fskin::rigged_image_avatar(trained.avatar, dataset.character().skeleton, resolution,
                                                    bones ? bones->detach().to(torch::kCPU, torch::kFloat32)
                                                          : torch::Tensor(),
                                                    fps);
        character.influences = influences;
        fskin::write_skinned_gltf(out, character);
      },
      py::arg("run"), py::arg("out"), py::arg("bones") = py::none(), py::arg("resolution") = 128, py::arg("fps") = 30.0,
      py::arg("influences") = 4, py::arg("data") = "", py::arg("mesh") = false, py::arg("subdivisions") = -1,
      "`fskin avatar export`: the avatar as a rigged glTF character (.glb/.gltf): its coloured surface (COLOR_0), "
      "the skinning weights it is posed with, the dataset's skeleton; bones [T, J, 4, 4] (canonical -> posed) as "
      "an animation. A Gaussian avatar's run: its Gaussians as a 3DGS .ply (every weight) or a glTF with "
      "KHR_gaussian_splatting (influences apply), with weights, skeleton and animation (resolution does not apply); "
      "with mesh=True the character's mesh, subdivided `subdivisions` times (-1: to the Gaussians' number), with "
      "the Gaussians' colours baked into its vertices, as a skinned glTF (`avatar export --mesh`)");
  m.def(
      "train_avatar",
      [](const std::string& data, const std::string& out, int64_t steps, int64_t rays_per_step, bool resume,
         uint64_t seed, bool progress, const std::vector<std::string>& settings, const std::string& config) {
        fskin::AvatarTrainOptions options;
        options.data_dir = data;
        options.out_dir = out;
        options.steps = steps;
        options.rays_per_step = rays_per_step;
        options.resume = resume;
        options.seed = seed;
        options.progress = progress;
        options = fskin::configure_avatar_options(options, config, settings);  // as `fskin avatar train`
        fskin::AvatarTrainSummary summary;
        {
          py::gil_scoped_release release;
          const fskin::SingleThreadedBlasScope blas;  // as `fskin avatar train` runs
          summary = fskin::train_avatar(options);
        }
        return py::dict(py::arg("first_step") = summary.first_step, py::arg("last_step") = summary.last_step,
                        py::arg("seconds") = summary.seconds, py::arg("loss") = summary.final_loss,
                        py::arg("batch_psnr") = summary.final_psnr);
      },
      py::arg("data"), py::arg("out"), py::arg("steps") = 2000, py::arg("rays_per_step") = 4096,
      py::arg("resume") = false, py::arg("seed") = 0, py::arg("progress") = false,
      py::arg("settings") = std::vector<std::string>{}, py::arg("config") = "",
      "`fskin avatar train`: a radiance field through the Fast-SNARF deformer from an image dataset; every option "
      "of the avatar's config (radiance/avatar_config.h) through settings ['model.occupancy_grid.every=50', ...] "
      "and a config file");
  m.def(
      "train_gaussian_avatar",
      [](const std::string& data, const std::string& out, int64_t steps, bool resume, uint64_t seed, bool progress,
         const std::vector<std::string>& settings, const std::string& config) {
        fskin::GaussianTrainOptions options;
        options.data_dir = data;
        options.out_dir = out;
        options.steps = steps;
        options.seed = seed;
        options = fskin::configure_gaussian_options(options, config, settings);  // as `fskin avatar train`
        options.resume = resume;
        options.progress = progress;
        fskin::GaussianTrainSummary summary;
        {
          py::gil_scoped_release release;
          const fskin::SingleThreadedBlasScope blas;
          summary = fskin::train_gaussian_avatar(options);
        }
        return py::dict(py::arg("first_step") = summary.first_step, py::arg("last_step") = summary.last_step,
                        py::arg("seconds") = summary.seconds, py::arg("loss") = summary.final_loss,
                        py::arg("psnr") = summary.final_psnr, py::arg("gaussians") = summary.gaussians,
                        py::arg("pose_pass_first_step") = summary.pose_pass_first_step,
                        py::arg("pose_pass_last_step") = summary.pose_pass_last_step);
      },
      py::arg("data"), py::arg("out"), py::arg("steps") = 3000, py::arg("resume") = false, py::arg("seed") = 0,
      py::arg("progress") = false, py::arg("settings") = std::vector<std::string>{}, py::arg("config") = "",
      "`fskin avatar train --representation gaussians`: articulated 3-D Gaussians from an image dataset; every "
      "option of their config (gaussians/gaussian_config.h) through settings ['density.every=50', ...] and a "
      "config file; evaluate_avatar, render_avatar and export_avatar take the run. Refining poses, a first pass "
      "learns them (pose_pass_first_step -> pose_pass_last_step in the returned dict)");
  m.def(
      "evaluate_avatar",
      [](const std::string& run, const std::string& split, const std::string& data, int64_t max_images,
         int64_t fit_poses, bool mesh) {
        fskin::PoseFittingOptions fitting;
        fitting.steps = fit_poses;
        py::gil_scoped_release release;
        const bool gaussians = fskin::is_gaussian_avatar_run(run);
        FSKIN_CHECK(!mesh || gaussians, "{}: mesh=True scores a Gaussian avatar's baked mesh; this is a volume avatar",
                    run);
        FSKIN_CHECK(!mesh || fit_poses == 0, "fit_poses fits the Gaussians' poses; it does not apply with mesh=True");
        const auto scores =
            mesh        ? fskin::evaluate_baked_gaussian_mesh(run, data, split, max_images, false)
            : gaussians ? fskin::evaluate_gaussian_avatar_run(run, data, split, max_images, false, fitting)
                        : fskin::evaluate_avatar_run(run, data, split, max_images, false, fitting);
        py::gil_scoped_acquire acquire;
        return py::module_::import("json").attr("loads")(scores.to_json());
      },
      py::arg("run"), py::arg("split") = "novel_view", py::arg("data") = "", py::arg("max_images") = 0,
      py::arg("fit_poses") = 0, py::arg("mesh") = false,
      "`fskin avatar eval`: PSNR / SSIM per image of a split, as a dict (mean_psnr, mean_ssim, frames, ...); "
      "fit_poses > 0: each image's pose fitted to it first (test-time pose optimisation); mesh=True: a Gaussian "
      "avatar's baked mesh (`avatar export --mesh`) scored instead of its Gaussians");
  m.def(
      "render_avatar",
      [](const std::string& run, const torch::Tensor& bones, const torch::Tensor& intrinsic,
         const torch::Tensor& extrinsic, int width, int height, std::vector<double> background) {
        FSKIN_CHECK(background.size() == 3, "render_avatar: background must have 3 components");
        const auto camera = fskin::PinholeCamera::from_matrices(intrinsic, extrinsic, width, height, "render_avatar");
        py::gil_scoped_release release;
        const std::array<double, 3> color{background[0], background[1], background[2]};
        const auto [rgb, opacity] = fskin::is_gaussian_avatar_run(run)
                                        ? fskin::TrainedGaussianAvatar::load(run).render(bones, camera, color)
                                        : fskin::TrainedAvatar::load(run).render(bones, camera, color);
        py::gil_scoped_acquire acquire;
        return py::make_tuple(rgb, opacity);
      },
      py::arg("run"), py::arg("bones"), py::arg("intrinsic"), py::arg("extrinsic"), py::arg("width"),
      py::arg("height"), py::arg("background") = std::vector<double>{1.0, 1.0, 1.0},
      "Render a trained avatar in bones [J, 4, 4] (canonical -> posed) by an OpenCV camera: (rgb [H, W, 3], "
      "opacity [H, W])");
}

}  // namespace fskin::python

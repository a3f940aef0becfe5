#include "fskin/radiance/image_dataset_builder.h"

#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "fskin/core/error.h"
#include "fskin/core/plausibility.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/data/build_manifest.h"
#include "fskin/data/dataset_builder.h"
#include "fskin/data/random.h"
#include "fskin/export/image.h"
#include "fskin/export/render.h"
#include "fskin/geometry/mesh_topology.h"
#include "fskin/io/npz.h"
#include "fskin/radiance/avatar_character.h"
#include "fskin/radiance/image_dataset.h"
#include "fskin/radiance/surface_texture.h"
#include "fskin/skeleton/forward_kinematics.h"
#include "fskin/skeleton/lbs.h"
#include "fskin/skeleton/skeleton.h"
#include "fskin/util/atomic_file.h"
#include "fskin/util/progress.h"
#include "fskin/version.h"

namespace fskin {
namespace {

namespace fs = std::filesystem;

// One image to render: which poses, which camera, the posed character.
struct ImagePlan {
  std::string split;
  int64_t index = 0;  // within the split
  int64_t pose_index = 0, view_index = 0;
  torch::Tensor bones;     // [J, 4, 4] canonical -> posed
  torch::Tensor vertices;  // [V, 3] posed
  Eigen::Vector3f light_scale = Eigen::Vector3f::Ones();  // ImageDatasetOptions::light_change
};

// Training pose p's per-channel factors in [1 - change, 1 + change]
// (ImageDatasetOptions::light_change), drawn from pose p's own stream, so
// that a dataset rebuilt or resumed draws the same.
Eigen::Vector3f light_change_factors(int64_t p, double change) {
  auto rng = Rng::for_item(/*seed=*/0x11647, static_cast<uint64_t>(p));
  Eigen::Vector3f out;
  for (int c = 0; c < 3; ++c) out[c] = static_cast<float>(rng.uniform(1 - change, 1 + change));
  return out;
}

// A rotation by `angle` about +Y through `centre` as a 4x4 transform.
torch::Tensor turn_about_y(double angle, const torch::Tensor& centre) {
  auto t = torch::eye(4, torch::kFloat32);
  const float c = static_cast<float>(std::cos(angle)), s = static_cast<float>(std::sin(angle));
  t[0][0] = c, t[0][2] = s, t[2][0] = -s, t[2][2] = c;
  const auto rotation = t.slice(0, 0, 3).slice(1, 0, 3);
  t.slice(0, 0, 3).select(1, 3).copy_(centre - rotation.matmul(centre));
  return t;
}

torch::Tensor matrices(const std::vector<PinholeCamera>& cameras, bool intrinsic) {
  std::vector<torch::Tensor> rows;
  for (const auto& c : cameras) {
    if (intrinsic) {
      Eigen::Matrix<double, 3, 3, Eigen::RowMajor> k = c.intrinsic;
      rows.push_back(torch::from_blob(k.data(), {3, 3}, torch::kFloat64).clone());
    } else {
      Eigen::Matrix<double, 4, 4, Eigen::RowMajor> e = c.extrinsic;
      rows.push_back(torch::from_blob(e.data(), {4, 4}, torch::kFloat64).clone());
    }
  }
  return torch::stack(rows);
}

}  // namespace

void ImageDatasetOptions::validate() const {
  FSKIN_CHECK(!out_dir.empty(), "image dataset: --out is empty");
  FSKIN_CHECK(width >= 8 && height >= 8 && width <= 4096 && height <= 4096,
              "image dataset: image size must be within 8..4096, got {}x{}", width, height);
  FSKIN_CHECK(supersampling >= 1 && supersampling <= 8, "image dataset: supersampling must be within 1..8, got {}",
              supersampling);
  FSKIN_CHECK(training_views >= 1 && training_views <= 64, "image dataset: training views must be within 1..64, got {}",
              training_views);
  FSKIN_CHECK(held_out_views >= 1 && held_out_views <= 64, "image dataset: held-out views must be within 1..64, got {}",
              held_out_views);
  FSKIN_CHECK(std::abs(elevation_degrees) < 80, "image dataset: elevation must be within (-80, 80) degrees, got {}",
              elevation_degrees);
  FSKIN_CHECK(novel_view_frames >= 0, "image dataset: novel-view frames must be >= 0, got {}", novel_view_frames);
  for (const double c : background)
    FSKIN_CHECK(c >= 0 && c <= 1, "image dataset: background components must be within [0, 1], got {}", c);
  for (const double c : light)
    FSKIN_CHECK(std::isfinite(c), "image dataset: the light direction must be finite, got {}", c);
  FSKIN_CHECK(ambient >= 0 && ambient <= 1, "image dataset: ambient must be within [0, 1], got {}", ambient);
  FSKIN_CHECK(light_change >= 0 && light_change < 1, "image dataset: light change must be within [0, 1), got {}",
              light_change);
  FSKIN_CHECK(texture == "plain" || texture == "photographic",
              "image dataset: the texture must be plain or photographic, got '{}'", texture);
}

std::string ImageDatasetSummary::to_string() const {
  return fmt::format("{} images written, {} already there (train {}, novel_view {}, novel_pose {})", images_written,
                     images_skipped, train, novel_view, novel_pose);
}

ImageDatasetSummary build_image_dataset(const BodyModel& model, const PoseSet& poses, const PoseSet& held_out_poses,
                                        const ImageDatasetOptions& options) {
  options.validate();
  torch::NoGradGuard no_grad;
  const auto& names = model.data().joint_names;
  poses.validate(options.poses_source, model.num_joints(), names);
  if (held_out_poses.size() > 0) held_out_poses.validate(options.ood_poses_source, model.num_joints(), names);

  const auto canonical_aa = canonical_pose(model, options.canonical_pose);
  const auto canonical = model.pose(canonical_aa.unsqueeze(0));
  RiggedMesh character;
  character.mesh = Mesh{canonical.vertices[0].contiguous(), model.data().faces, {}};
  character.weights = model.data().weights;
  character.skeleton = Skeleton{names, model.data().parents, canonical.joints[0].contiguous()};
  const auto& bind_vertices = character.mesh.vertices;
  const SurfaceTexture texture(bind_vertices, character.weights, names, options.texture == "photographic");
  const Eigen::Vector3d light_d(options.light[0], options.light[1], options.light[2]);
  const bool lit = light_d.norm() > 0;
  const Eigen::Vector3f light = lit ? Eigen::Vector3f(light_d.normalized().cast<float>()) : Eigen::Vector3f::Zero();
  const float ambient = static_cast<float>(options.ambient);
  const auto centre = ((std::get<0>(bind_vertices.min(0)) + std::get<0>(bind_vertices.max(0))) / 2);

  // Every image: posed bones and vertices.
  std::vector<ImagePlan> plan;
  const auto posed_frame = [&](const PoseSet& set, int64_t p, double turn) {
    const auto& moved = set.joint_translations;
    const auto posed = model.pose(set.poses[p].unsqueeze(0), {}, set.trans[p].unsqueeze(0),
                                  moved.defined() ? moved[p].unsqueeze(0) : torch::Tensor());
    auto bones = relative_bone_transforms(posed.bone_transforms, canonical.bone_transforms)[0];
    auto vertices = posed.vertices[0];
    if (turn != 0) {
      const auto t = turn_about_y(turn, centre);
      bones = t.matmul(bones);
      vertices = transform_points(t, vertices);
    }
    return std::make_pair(bones.contiguous(), vertices.contiguous());
  };
  const int64_t n_train = poses.size();
  const auto train_turn = [&](int64_t p) {
    return options.monocular ? 2 * M_PI * static_cast<double>(p) / static_cast<double>(n_train) : 0.0;
  };
  const int train_views = options.monocular ? 1 : options.training_views;
  std::map<std::string, int64_t> split_sizes;
  const auto add = [&](const std::string& split, int64_t pose_index, int64_t view, const PoseSet& set, double turn) {
    ImagePlan item;
    item.split = split;
    item.index = split_sizes[split]++;
    item.pose_index = pose_index;
    item.view_index = view;
    std::tie(item.bones, item.vertices) = posed_frame(set, pose_index, turn);
    if (split != "novel_pose" && options.light_change > 0)
      item.light_scale = light_change_factors(pose_index, options.light_change);
    plan.push_back(std::move(item));
  };
  for (int64_t p = 0; p < n_train; ++p)
    for (int v = 0; v < train_views; ++v) add("train", p, v, poses, train_turn(p));
  const int64_t n_novel_view = std::min<int64_t>(options.novel_view_frames, n_train);
  for (int64_t k = 0; k < n_novel_view; ++k) {
    const int64_t p = (k * n_train) / std::max<int64_t>(n_novel_view, 1);
    add("novel_view", p, train_views + k % options.held_out_views, poses, train_turn(p));
  }
  for (int64_t p = 0; p < held_out_poses.size(); ++p)
    add("novel_pose", p, train_views + p % options.held_out_views, held_out_poses, 0.0);

  // Cameras: a ring around the union of every posed frame, each placed where
  // that union fits into its picture (export/render.h, frame_camera).
  BoundingBox box;
  for (const auto& item : plan) {
    const auto lo = std::get<0>(item.vertices.min(0)), hi = std::get<0>(item.vertices.max(0));
    box.extend(Eigen::Vector3f(lo[0].item<float>(), lo[1].item<float>(), lo[2].item<float>()));
    box.extend(Eigen::Vector3f(hi[0].item<float>(), hi[1].item<float>(), hi[2].item<float>()));
  }
  std::vector<PinholeCamera> views;
  const auto ring_camera = [&](double azimuth) {
    return frame_camera(box, ViewAngles{azimuth, options.elevation_degrees}, options.width, options.height,
                        options.vertical_fov_degrees, 0.04);
  };
  for (int v = 0; v < train_views; ++v) views.push_back(ring_camera(360.0 * v / train_views));
  for (int v = 0; v < options.held_out_views; ++v)
    views.push_back(ring_camera(360.0 * (v + 0.5) / options.held_out_views));

  std::array<double, 3> background;
  Rgb8 background8;
  for (int c = 0; c < 3; ++c) {
    background8[c] = static_cast<uint8_t>(std::lround(255 * options.background[c]));
    background[c] = background8[c] / 255.0;
  }
  nlohmann::json counts = nlohmann::json::object();
  for (const auto& split : image_split_names()) counts[split] = 0;
  for (const auto& item : plan) counts[item.split] = counts[item.split].get<int64_t>() + 1;
  nlohmann::json manifest = {
      {"format", "fskin-image-dataset"},
      {"format_version", kImageDatasetFormatVersion},
      {"fskin_version", FSKIN_VERSION},
      {"model", options.model_source},
      {"poses", options.poses_source},
      {"held_out_poses", options.ood_poses_source},
      {"num_joints", model.num_joints()},
      {"joint_names", names},
      {"parents", model.data().parents},
      {"canonical_pose", resolve_canonical_pose(model, options.canonical_pose)},
      {"canonical_pose_option", options.canonical_pose},
      {"width", options.width},
      {"height", options.height},
      {"supersampling", options.supersampling},
      {"monocular", options.monocular},
      {"training_views", train_views},
      {"held_out_views", options.held_out_views},
      {"elevation_degrees", options.elevation_degrees},
      {"vertical_fov_degrees", options.vertical_fov_degrees},
      {"background", background},
      {"texture", fmt::format("fskin SurfaceTexture{}{}",
                              options.texture == "photographic" ? " with photograph-like detail" : "",
                              lit ? ", Lambert-shaded by a distant light" : " (unlit albedo)")},
      {"texture_detail", options.texture},
      {"counts", counts},
      {"splits", image_split_names()},
  };
  if (lit) {
    manifest["light"] = {options.light[0], options.light[1], options.light[2]};
    manifest["ambient"] = options.ambient;
  }
  if (options.light_change > 0) manifest["light_change"] = options.light_change;
  const fs::path dir(options.out_dir);
  const BuildManifest build_manifest(options.out_dir, manifest);
  save_canonical_character(character, (dir / "canonical.npz").string());

  // What the shader interpolates per sample: canonical positions and weights.
  const auto canonical_vertices_f = bind_vertices.to(torch::kFloat32).contiguous();
  const auto weights = character.weights.to(torch::kFloat32).contiguous();
  const auto faces_i = character.mesh.faces.to(torch::kInt64).contiguous();
  const float* canonical_vertices = canonical_vertices_f.data_ptr<float>();
  const float* weight_data = weights.data_ptr<float>();
  const int64_t* faces = faces_i.data_ptr<int64_t>();
  const int64_t J = model.num_joints();

  ImageDatasetSummary summary;
  for (const auto& split : image_split_names()) {
    std::vector<const ImagePlan*> items;
    for (const auto& item : plan)
      if (item.split == split) items.push_back(&item);
    const fs::path split_dir = dir / split;
    create_output_directory((split_dir / "images").string());
    create_output_directory((split_dir / "masks").string());
    remove_stale_temporaries((split_dir / "images").string());
    remove_stale_temporaries((split_dir / "masks").string());
    std::vector<PinholeCamera> cameras;
    std::vector<torch::Tensor> bones;
    std::vector<int64_t> pose_index, view_index;
    for (const auto* item : items) {
      cameras.push_back(views[item->view_index]);
      bones.push_back(item->bones);
      pose_index.push_back(item->pose_index);
      view_index.push_back(item->view_index);
    }
    io::NpzWriter camera_file;
    const bool one_camera = !view_index.empty() && std::all_of(view_index.begin(), view_index.end(),
                                                               [&](int64_t v) { return v == view_index[0]; });
    auto intrinsic = cameras.empty() ? torch::zeros({0, 3, 3}, torch::kFloat64) : matrices(cameras, true);
    auto extrinsic = cameras.empty() ? torch::zeros({0, 4, 4}, torch::kFloat64) : matrices(cameras, false);
    // One camera for the whole split is stored as PeopleSnapshot does: (3, 3) and (4, 4).
    if (one_camera) intrinsic = intrinsic[0].contiguous(), extrinsic = extrinsic[0].contiguous();
    camera_file.add("intrinsic", intrinsic);
    camera_file.add("extrinsic", extrinsic);
    camera_file.add("height", torch::tensor(int64_t{options.height}));
    camera_file.add("width", torch::tensor(int64_t{options.width}));
    camera_file.save((split_dir / "cameras.npz").string());
    io::NpzWriter pose_file;
    pose_file.add("bone_transforms",
                  bones.empty() ? torch::zeros({0, model.num_joints(), 4, 4}) : torch::stack(bones).contiguous());
    pose_file.add("pose_index", torch::tensor(pose_index, torch::kInt64));
    pose_file.add("view_index", torch::tensor(view_index, torch::kInt64));
    pose_file.save((split_dir / "poses.npz").string());

    ProgressBar progress("rendering " + split, static_cast<int64_t>(items.size()), options.progress);
    for (const auto* item : items) {
      const auto image_path = split_dir / "images" / image_file_name(item->index);
      const auto mask_path = split_dir / "masks" / mask_file_name(item->index);
      if (fs::exists(image_path) && fs::exists(mask_path)) {
        ++summary.images_skipped;
        progress.advance(1, "skipped " + image_file_name(item->index));
        continue;
      }
      const Mesh mesh{item->vertices, character.mesh.faces, {}};
      const auto normals = lit ? vertex_normals(mesh).to(torch::kFloat32).contiguous() : torch::Tensor();
      const float* normal_data = lit ? normals.data_ptr<float>() : nullptr;
      const auto shade = [&](int64_t face, float b0, float b1, float b2) {
        thread_local std::vector<float> w;
        w.assign(J, 0.0f);
        Eigen::Vector3f p = Eigen::Vector3f::Zero();
        const float b[3] = {b0, b1, b2};
        for (int k = 0; k < 3; ++k) {
          const int64_t v = faces[3 * face + k];
          p += b[k] * Eigen::Map<const Eigen::Vector3f>(canonical_vertices + 3 * v);
          for (int64_t j = 0; j < J; ++j) w[j] += b[k] * weight_data[v * J + j];
        }
        const Eigen::Vector3f albedo = texture.albedo(p, w.data());
        const Eigen::Vector3f& scale = item->light_scale;
        if (!lit) return Eigen::Vector3f(albedo.cwiseProduct(scale).cwiseMin(1.0f));
        Eigen::Vector3f n = Eigen::Vector3f::Zero();
        for (int k = 0; k < 3; ++k) n += b[k] * Eigen::Map<const Eigen::Vector3f>(normal_data + 3 * faces[3 * face + k]);
        const float lambert = std::max(0.0f, n.normalized().dot(light));
        return Eigen::Vector3f((albedo * (ambient + (1 - ambient) * lambert)).cwiseProduct(scale).cwiseMin(1.0f));
      };
      const auto render = render_surface(mesh, views[item->view_index], options.supersampling, shade, background8);
      write_png(image_path.string(), render.image);
      write_png_gray(mask_path.string(), options.width, options.height, render.mask);
      ++summary.images_written;
      progress.advance(1, image_file_name(item->index));
    }
    progress.finish();
    summary.train += split == "train" ? static_cast<int64_t>(items.size()) : 0;
    summary.novel_view += split == "novel_view" ? static_cast<int64_t>(items.size()) : 0;
    summary.novel_pose += split == "novel_pose" ? static_cast<int64_t>(items.size()) : 0;
  }
  build_manifest.mark_complete();
  return summary;
}

}  // namespace fskin

#include "fskin/radiance/image_dataset.h"

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
#include "fskin/export/image.h"
#include "fskin/export/render.h"
#include "fskin/io/npz.h"
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
constexpr int kImageDatasetFormatVersion = 1;

// One image to render: which poses, which camera, the posed character.
struct ImagePlan {
  std::string split;
  int64_t index = 0;  // within the split
  int64_t pose_index = 0, view_index = 0;
  torch::Tensor bones;     // [J, 4, 4] canonical -> posed
  torch::Tensor vertices;  // [V, 3] posed
};

std::string image_name(int64_t index) { return fmt::format("image_{:04d}.png", index); }
std::string mask_name(int64_t index) { return fmt::format("mask_{:04d}.png", index); }

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

nlohmann::json read_json(const std::string& path) {
  FSKIN_CHECK(fs::exists(path), "{}: missing (not an image dataset? build one with `fskin data images`)", path);
  try {
    return nlohmann::json::parse(read_file(path));
  } catch (const nlohmann::json::exception& e) {
    fail("{}: not valid JSON ({})", path, e.what());
  }
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
}

std::string ImageDatasetSummary::to_string() const {
  return fmt::format("{} images written, {} already there (train {}, novel_view {}, novel_pose {})", images_written,
                     images_skipped, train, novel_view, novel_pose);
}

void AvatarCharacter::save(const std::string& path) const {
  io::NpzWriter npz;
  npz.add("vertices", vertices.to(torch::kFloat32).contiguous());
  npz.add("faces", faces.to(torch::kInt64).contiguous());
  npz.add("weights", weights.to(torch::kFloat32).contiguous());
  npz.add("joints", joints.to(torch::kFloat32).contiguous());
  npz.add("parents", torch::tensor(parents, torch::kInt64));
  npz.add_strings("joint_names", joint_names);
  npz.save(path);
}

AvatarCharacter AvatarCharacter::load(const std::string& path) {
  FSKIN_CHECK(fs::exists(path), "{}: missing", path);
  const io::NpzReader npz(path);
  AvatarCharacter c;
  const auto floating = [&](const std::string& key) {
    auto t = npz.tensor(key);
    expect_floating(t, path + ": " + key);
    return t.to(torch::kFloat32);
  };
  const auto integral = [&](const std::string& key) {
    auto t = npz.tensor(key);
    FSKIN_CHECK(!t.is_floating_point() && t.scalar_type() != torch::kBool, "{}: {} must hold integers, got {}", path,
                key, std::string(c10::toString(t.scalar_type())));
    return t.to(torch::kInt64).contiguous();
  };
  c.vertices = floating("vertices");
  c.faces = integral("faces");
  c.weights = floating("weights");
  c.joints = floating("joints");
  const auto parents = integral("parents");
  expect_shape(parents, {-1}, path + ": parents");
  c.parents.assign(parents.data_ptr<int64_t>(), parents.data_ptr<int64_t>() + parents.numel());
  c.joint_names = npz.strings("joint_names");
  expect_shape(c.vertices, {-1, 3}, path + ": vertices");
  FSKIN_CHECK(c.vertices.size(0) > 0, "{}: no vertices", path);
  expect_shape(c.faces, {-1, 3}, path + ": faces");
  expect_shape(c.weights, {c.vertices.size(0), -1}, path + ": weights");
  expect_shape(c.joints, {c.weights.size(1), 3}, path + ": joints");
  expect_plausible(c.vertices, path + ": vertices");
  expect_finite(c.weights, path + ": weights");
  FSKIN_CHECK(c.num_joints() == c.weights.size(1) && static_cast<int64_t>(c.joint_names.size()) == c.num_joints(),
              "{}: {} parents and {} joint names for {} weight columns", path, c.parents.size(), c.joint_names.size(),
              c.weights.size(1));
  // The tree (one root first, parents before children, unique names) and finite joints.
  Skeleton{c.joint_names, c.parents, c.joints}.validate(path);
  expect_plausible(c.joints, path + ": joints");
  FSKIN_CHECK(c.faces.numel() == 0 || (c.faces.min().item<int64_t>() >= 0 &&
                                       c.faces.max().item<int64_t>() < c.vertices.size(0)),
              "{}: face indices out of range for {} vertices", path, c.vertices.size(0));
  FSKIN_CHECK(c.weights.min().item<float>() >= 0 && (c.weights.sum(1) - 1).abs().max().item<float>() < 1e-3,
              "{}: skinning weights must be >= 0 with rows summing to 1", path);
  return c;
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
  AvatarCharacter character;
  character.vertices = canonical.vertices[0].contiguous();
  character.faces = model.data().faces;
  character.weights = model.data().weights;
  character.joints = canonical.joints[0].contiguous();
  character.joint_names = names;
  character.parents = model.data().parents;
  const SurfaceTexture texture(character.vertices, character.weights, names);
  const auto centre = ((std::get<0>(character.vertices.min(0)) + std::get<0>(character.vertices.max(0))) / 2);

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
  const double aspect = static_cast<double>(options.width) / options.height;
  const auto ring_camera = [&](double azimuth) {
    const Camera camera = frame_camera(box, ViewAngles{azimuth, options.elevation_degrees}, aspect,
                                       options.vertical_fov_degrees, 0.04);
    return PinholeCamera::from_render_camera(camera, options.width, options.height);
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
  const nlohmann::json manifest = {
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
      {"texture", "fskin SurfaceTexture (unlit albedo)"},
      {"counts", counts},
      {"splits", image_split_names()},
  };
  const fs::path dir(options.out_dir);
  const BuildManifest build_manifest(options.out_dir, manifest);
  character.save((dir / "canonical.npz").string());

  // What the shader interpolates per sample: canonical positions and weights.
  const auto canonical_vertices_f = character.vertices.to(torch::kFloat32).contiguous();
  const auto weights = character.weights.to(torch::kFloat32).contiguous();
  const auto faces_i = character.faces.to(torch::kInt64).contiguous();
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
      const auto image_path = split_dir / "images" / image_name(item->index);
      const auto mask_path = split_dir / "masks" / mask_name(item->index);
      if (fs::exists(image_path) && fs::exists(mask_path)) {
        ++summary.images_skipped;
        progress.advance(1, "skipped " + image_name(item->index));
        continue;
      }
      const Mesh mesh{item->vertices, character.faces, {}};
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
        return texture.albedo(p, w.data());
      };
      const auto render = render_surface(mesh, views[item->view_index].to_render_camera(), options.width,
                                         options.height, options.supersampling, shade, background8);
      write_png(image_path.string(), render.image);
      write_png_gray(mask_path.string(), options.width, options.height, render.mask);
      ++summary.images_written;
      progress.advance(1, image_name(item->index));
    }
    progress.finish();
    summary.train += split == "train" ? static_cast<int64_t>(items.size()) : 0;
    summary.novel_view += split == "novel_view" ? static_cast<int64_t>(items.size()) : 0;
    summary.novel_pose += split == "novel_pose" ? static_cast<int64_t>(items.size()) : 0;
  }
  build_manifest.mark_complete();
  return summary;
}

namespace {

// Each camera must have the subject in front of it and near its image: the
// subject's centre (the canonical vertices' mean carried by the bones, each
// by its share of the weights) projected with the image's camera.
void check_cameras_see_the_subject(const ImageSplit& split, const AvatarCharacter& character,
                                   const std::string& camera_path) {
  if (split.size() == 0) return;
  const auto centre = character.vertices.to(torch::kFloat64).mean(0);          // [3]
  const auto share = character.weights.to(torch::kFloat64).mean(0);            // [J]
  const auto bones = split.bone_transforms.to(torch::kFloat64);               // [N, J, 4, 4]
  const auto moved = torch::matmul(bones.narrow(2, 0, 3).narrow(3, 0, 3), centre) +
                     bones.narrow(2, 0, 3).select(3, 3);                       // [N, J, 3]
  const auto posed = (moved * share.view({1, -1, 1})).sum(1) / share.sum();   // [N, 3]
  const auto a = posed.accessor<double, 2>();
  for (int64_t i = 0; i < split.size(); ++i) {
    const auto& camera = split.cameras[i];
    const Eigen::Vector3d world(a[i][0], a[i][1], a[i][2]);
    const Eigen::Vector3d in_camera =
        camera.extrinsic.topLeftCorner<3, 3>() * world + camera.extrinsic.topRightCorner<3, 1>();
    FSKIN_CHECK(in_camera.z() > 0, "{}: camera {} has the subject behind it (its centre at depth {:.3g})", camera_path,
                i, in_camera.z());
    const Eigen::Vector2d pixel = camera.project(world);
    FSKIN_CHECK(pixel.x() > -camera.width && pixel.x() < 2.0 * camera.width && pixel.y() > -camera.height &&
                    pixel.y() < 2.0 * camera.height,
                "{}: camera {} does not see the subject (its centre projects to pixel ({:.4g}, {:.4g}), far outside the "
                "{}x{} image)",
                camera_path, i, pixel.x(), pixel.y(), camera.width, camera.height);
  }
}

// A split whose masks are all empty has no subject to learn; some empty
// masks (the subject out of frame) are reported.
void check_masks_hold_a_subject(const ImageSplit& split, const std::string& mask_dir) {
  if (split.size() == 0) return;
  const auto subject_pixels = (split.masks > 127).flatten(1).sum(1);
  const int64_t empty = (subject_pixels == 0).sum().item<int64_t>();
  FSKIN_CHECK(empty < split.size(), "{}: all {} masks are empty (no pixel above 127): there is no subject to learn",
              mask_dir, split.size());
  if (empty > 0)
    std::fprintf(stderr, "fskin: warning: %s: %lld of %lld masks are empty (no subject in view)\n", mask_dir.c_str(),
                 static_cast<long long>(empty), static_cast<long long>(split.size()));
}

}  // namespace

std::vector<PinholeCamera> load_cameras(const std::string& camera_path, int64_t n) {
  FSKIN_CHECK(fs::exists(camera_path), "{}: missing", camera_path);
  std::vector<PinholeCamera> cameras;
  const io::NpzReader camera_file(camera_path);
  auto intrinsic = camera_file.tensor("intrinsic");
  auto extrinsic = camera_file.tensor("extrinsic");
  expect_floating(intrinsic, camera_path + ": intrinsic");
  expect_floating(extrinsic, camera_path + ": extrinsic");
  intrinsic = intrinsic.to(torch::kFloat64);
  extrinsic = extrinsic.to(torch::kFloat64);
  const auto height = camera_file.tensor("height").reshape({-1}).to(torch::kFloat64);
  const auto width = camera_file.tensor("width").reshape({-1}).to(torch::kFloat64);
  FSKIN_CHECK(height.numel() == 1 && width.numel() == 1, "{}: height and width must be single numbers", camera_path);
  const double h = height.item<double>(), w = width.item<double>();
  FSKIN_CHECK(h >= 1 && w >= 1 && h <= kMaxImageSide && w <= kMaxImageSide && h == std::floor(h) && w == std::floor(w),
              "{}: height and width must be whole numbers within 1..{}, got {:g} x {:g}", camera_path, kMaxImageSide,
              w, h);
  const std::string layout = "one camera, or one per image of poses.npz";
  FSKIN_CHECK((intrinsic.dim() == 2 || intrinsic.dim() == 3) && intrinsic.size(-2) == 3 && intrinsic.size(-1) == 3,
              "{}: intrinsic must be (3, 3) or (N, 3, 3) ({}), got {}", camera_path, layout,
              shape_string(intrinsic.sizes()));
  FSKIN_CHECK((extrinsic.dim() == 2 || extrinsic.dim() == 3) && (extrinsic.size(-2) == 3 || extrinsic.size(-2) == 4) &&
                  extrinsic.size(-1) == 4,
              "{}: extrinsic must be (4, 4), (3, 4), (N, 4, 4) or (N, 3, 4) ({}), got {}", camera_path, layout,
              shape_string(extrinsic.sizes()));
  if (n < 0) n = extrinsic.dim() == 3 ? extrinsic.size(0) : intrinsic.dim() == 3 ? intrinsic.size(0) : 1;
  if (intrinsic.dim() == 2) intrinsic = intrinsic.unsqueeze(0).expand({n, 3, 3});
  if (extrinsic.dim() == 2) extrinsic = extrinsic.unsqueeze(0).expand({n, -1, -1});
  if (extrinsic.size(1) == 3)  // [R | t] without the last row
    extrinsic = torch::cat({extrinsic, torch::tensor({0.0, 0.0, 0.0, 1.0}, torch::kFloat64).expand({extrinsic.size(0), 1, 4})}, 1);
  expect_shape(intrinsic, {n, 3, 3}, camera_path + ": intrinsic (" + layout + ")");
  expect_shape(extrinsic, {n, 4, 4}, camera_path + ": extrinsic (" + layout + ")");
  expect_plausible(extrinsic, camera_path + ": extrinsic");
  intrinsic = intrinsic.contiguous();
  extrinsic = extrinsic.contiguous();
  for (int64_t i = 0; i < n; ++i) {
    PinholeCamera camera;
    camera.width = static_cast<int>(w);
    camera.height = static_cast<int>(h);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) camera.intrinsic(r, c) = intrinsic[i][r][c].item<double>();
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) camera.extrinsic(r, c) = extrinsic[i][r][c].item<double>();
    camera.validate(fmt::format("{}: camera {}", camera_path, i));
    cameras.push_back(camera);
  }
  return cameras;
}

ImageDataset::ImageDataset(std::string dir) : dir_(std::move(dir)) {
  const auto manifest_path = (fs::path(dir_) / "manifest.json").string();
  const auto manifest = read_json(manifest_path);
  try {
    FSKIN_CHECK(manifest.at("format").get<std::string>() == "fskin-image-dataset",
                "{}: format is '{}', not an fskin image dataset", manifest_path, manifest.at("format").dump());
    FSKIN_CHECK(manifest.value("complete", true),
                "{}: the dataset is incomplete (its build was interrupted); run `fskin data images` again with "
                "the same arguments to finish it",
                manifest_path);
    const auto bg = manifest.at("background").get<std::vector<double>>();
    FSKIN_CHECK(bg.size() == 3, "{}: background must have 3 components", manifest_path);
    for (const double c : bg)
      FSKIN_CHECK(c >= 0 && c <= 1, "{}: background components must be within [0, 1] (linear RGB), got {}",
                  manifest_path, c);
    std::copy(bg.begin(), bg.end(), background_.begin());
    splits_ = manifest.at("splits").get<std::vector<std::string>>();
    for (const auto& split : splits_) {
      // A split is a directory of this dataset: a plain name, not a path.
      const bool plain = !split.empty() && split != "." && split != ".." && split.find_first_of("/\\") == std::string::npos;
      FSKIN_CHECK(plain, "{}: split '{}' is not a directory name inside the dataset", manifest_path, split);
    }
    model_source_ = manifest.value("model", std::string());
    canonical_pose_option_ = manifest.value("canonical_pose_option", std::string("default"));
  } catch (const nlohmann::json::exception& e) {
    fail("{}: {}", manifest_path, e.what());
  }
  character_ = AvatarCharacter::load((fs::path(dir_) / "canonical.npz").string());
}

ImageSplit ImageDataset::load_split(const std::string& split) const {
  FSKIN_CHECK(std::find(splits_.begin(), splits_.end(), split) != splits_.end(),
              "{}: no split '{}' (it has: {})", dir_, split, fmt::format("{}", fmt::join(splits_, ", ")));
  const fs::path split_dir = fs::path(dir_) / split;
  ImageSplit out;
  out.name = split;
  const std::string pose_path = (split_dir / "poses.npz").string();
  FSKIN_CHECK(fs::exists(pose_path), "{}: missing", pose_path);
  const io::NpzReader pose_file(pose_path);
  out.bone_transforms = pose_file.tensor("bone_transforms");
  expect_floating(out.bone_transforms, pose_path + ": bone_transforms");
  out.bone_transforms = out.bone_transforms.to(torch::kFloat32).contiguous();
  expect_shape(out.bone_transforms, {-1, character_.num_joints(), 4, 4},
               pose_path + ": bone_transforms (for the " + std::to_string(character_.num_joints()) +
                   " joints of canonical.npz)");
  expect_plausible(out.bone_transforms, pose_path + ": bone_transforms");
  const int64_t n = out.bone_transforms.size(0);
  out.pose_index = pose_file.contains("pose_index") ? pose_file.tensor("pose_index").to(torch::kInt64)
                                                    : torch::arange(n, torch::kInt64);
  out.view_index = pose_file.contains("view_index") ? pose_file.tensor("view_index").to(torch::kInt64)
                                                    : torch::zeros({n}, torch::kInt64);
  expect_shape(out.pose_index, {n}, pose_path + ": pose_index");
  expect_shape(out.view_index, {n}, pose_path + ": view_index");

  const std::string camera_path = (split_dir / "cameras.npz").string();
  out.cameras = load_cameras(camera_path, n);
  const int W = n > 0 ? out.cameras[0].width : 0, H = n > 0 ? out.cameras[0].height : 0;
  out.images = torch::empty({n, H, W, 3}, torch::kUInt8);
  out.masks = torch::empty({n, H, W}, torch::kUInt8);
  for (int64_t i = 0; i < n; ++i) {
    const auto image_path = (split_dir / "images" / image_name(i)).string();
    const auto mask_path = (split_dir / "masks" / mask_name(i)).string();
    FSKIN_CHECK(fs::exists(image_path), "{}: missing ({} has {} frames)", image_path, pose_path, n);
    FSKIN_CHECK(fs::exists(mask_path), "{}: missing ({} has {} frames)", mask_path, pose_path, n);
    const Image image = read_png(image_path);
    FSKIN_CHECK(image.width == W && image.height == H, "{}: {}x{} pixels, but {} says {}x{}", image_path, image.width,
                image.height, camera_path, W, H);
    std::memcpy(out.images[i].data_ptr<uint8_t>(), image.rgb.data(), image.rgb.size());
    int mw = 0, mh = 0;
    const auto mask = read_png_gray(mask_path, mw, mh);
    FSKIN_CHECK(mw == W && mh == H, "{}: {}x{} pixels, but {} says {}x{}", mask_path, mw, mh, camera_path, W, H);
    std::memcpy(out.masks[i].data_ptr<uint8_t>(), mask.data(), mask.size());
  }
  check_cameras_see_the_subject(out, character_, camera_path);
  check_masks_hold_a_subject(out, (split_dir / "masks").string());
  return out;
}

torch::Tensor ImageDataset::bone_transforms(const PoseSet& poses, const std::string& context,
                                           const std::string& model_path) const {
  torch::NoGradGuard no_grad;
  const std::string path = model_path.empty() ? model_source_ : model_path;
  FSKIN_CHECK(!path.empty(), "{}: the manifest records no body model; pass one to pose new poses", dir_);
  FSKIN_CHECK(fs::exists(path), "{}: body model {} (recorded in its manifest) is missing; pass the model file", dir_,
              path);
  const auto model = BodyModel::load(path);
  poses.validate(context, model.num_joints(), model.data().joint_names);
  const auto canonical = model.pose(canonical_pose(model, canonical_pose_option_).unsqueeze(0));
  FSKIN_CHECK(canonical.vertices[0].sizes() == character_.vertices.sizes() &&
                  torch::allclose(canonical.vertices[0], character_.vertices, 1e-4, 1e-5),
              "{}: {} is not the body model this dataset was built from (its canonical vertices differ)", dir_, path);
  const auto& moved = poses.joint_translations;
  const auto posed = model.pose(poses.poses, {}, poses.trans, moved.defined() ? moved : torch::Tensor());
  return relative_bone_transforms(posed.bone_transforms, canonical.bone_transforms).contiguous();
}

std::array<int64_t, 4> mask_box(const torch::Tensor& mask, double grow) {
  FSKIN_CHECK(mask.dim() == 2, "mask_box: mask must be [H, W]");
  const int64_t H = mask.size(0), W = mask.size(1);
  const auto on = mask > 0;
  const auto rows = torch::nonzero(on.any(1)).reshape({-1}), cols = torch::nonzero(on.any(0)).reshape({-1});
  if (rows.numel() == 0) return {0, 0, W, H};
  const int64_t v0 = rows.min().item<int64_t>(), v1 = rows.max().item<int64_t>() + 1;
  const int64_t u0 = cols.min().item<int64_t>(), u1 = cols.max().item<int64_t>() + 1;
  const auto gu = static_cast<int64_t>(std::ceil(0.5 * grow * static_cast<double>(u1 - u0)));
  const auto gv = static_cast<int64_t>(std::ceil(0.5 * grow * static_cast<double>(v1 - v0)));
  return {std::max<int64_t>(0, u0 - gu), std::max<int64_t>(0, v0 - gv), std::min(W, u1 + gu), std::min(H, v1 + gv)};
}

}  // namespace fskin

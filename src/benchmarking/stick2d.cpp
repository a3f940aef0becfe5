#include "fskin/benchmarking/stick2d.h"
#include "fskin/data/dataset.h"

#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>

#include <nlohmann/json.hpp>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/data/random.h"
#include "fskin/skeleton/forward_kinematics.h"
#include "fskin/skeleton/rotations.h"
#include "fskin/util/atomic_file.h"
#include "fskin/util/progress.h"
#include "fskin/version.h"

namespace fskin {
namespace {

struct Vec2 {
  double x, y;
};

// 2x3 affine part of a bone transform, in the plane.
struct Affine2 {
  double r00, r01, r10, r11, tx, ty;
  Vec2 apply(Vec2 p) const { return {r00 * p.x + r01 * p.y + tx, r10 * p.x + r11 * p.y + ty}; }
};

std::vector<Affine2> planar_bones(const torch::Tensor& bones) {
  expect_shape(bones, {2, 4, 4}, "stick bones");
  const auto b = bones.to(torch::kFloat64).contiguous();
  const double* m = b.data_ptr<double>();
  std::vector<Affine2> out;
  for (int j = 0; j < 2; ++j, m += 16) out.push_back({m[0], m[1], m[4], m[5], m[3], m[7]});
  return out;
}

std::vector<Vec2> planar_points(const torch::Tensor& points, const char* what) {
  FSKIN_CHECK(points.dim() == 2 && (points.size(1) == 2 || points.size(1) == 3),
              "{}: expected [N, 2] or [N, 3], got {}", what, shape_string(points.sizes()));
  const auto p = points.to(torch::kFloat64).contiguous();
  const double* v = p.data_ptr<double>();
  std::vector<Vec2> out(static_cast<size_t>(p.size(0)));
  for (size_t i = 0; i < out.size(); ++i) out[i] = {v[i * p.size(1)], v[i * p.size(1) + 1]};
  return out;
}

double distance_to_segment(Vec2 p, double x0, double x1) {
  const double x = std::clamp(p.x, x0, x1);
  return std::hypot(p.x - x, p.y);
}

bool in_object(const StickOptions& o, Vec2 p) {
  return o.with_object &&
         std::hypot(p.x - o.object_centre[0], p.y - o.object_centre[1]) < o.object_radius;
}

std::array<double, 2> weights_at(const StickOptions& o, Vec2 p) {
  if (in_object(o, p)) return {1.0, 0.0};
  // SNARF sec. 4.1: inverse distance to each bone, normalised. A point on a
  // bone gets (nearly) all of its weight.
  constexpr double kMinDistance = 1e-9;
  const double a = 1.0 / std::max(distance_to_segment(p, 0.0, o.bone_length), kMinDistance);
  const double b =
      1.0 / std::max(distance_to_segment(p, o.bone_length, 2 * o.bone_length), kMinDistance);
  return {a / (a + b), b / (a + b)};
}

// The canonical rectangle's outline, counter-clockwise, evenly spaced.
std::vector<Vec2> canonical_outline(const StickOptions& o) {
  const double L = 2 * o.bone_length, h = o.half_width;
  const Vec2 corners[5] = {{0, -h}, {L, -h}, {L, h}, {0, h}, {0, -h}};
  const double perimeter = 2 * L + 4 * h;
  std::vector<Vec2> out;
  for (int64_t k = 0; k < o.outline_vertices; ++k) {
    double s = perimeter * static_cast<double>(k) / static_cast<double>(o.outline_vertices);
    int side = 0;
    for (;; ++side) {
      const double len = std::hypot(corners[side + 1].x - corners[side].x,
                                    corners[side + 1].y - corners[side].y);
      if (s <= len || side == 3) {
        const double t = s / len;
        out.push_back({corners[side].x + t * (corners[side + 1].x - corners[side].x),
                       corners[side].y + t * (corners[side + 1].y - corners[side].y)});
        break;
      }
      s -= len;
    }
  }
  return out;
}

Vec2 skin(const StickOptions& o, const std::vector<Affine2>& bones, Vec2 p) {
  const auto w = weights_at(o, p);
  const Vec2 a = bones[0].apply(p), b = bones[1].apply(p);
  return {w[0] * a.x + w[1] * b.x, w[0] * a.y + w[1] * b.y};
}

// Winding number of a closed polygon around p (Sunday's signed crossings).
int winding_number(const std::vector<Vec2>& polygon, Vec2 p) {
  int w = 0;
  for (size_t i = 0; i < polygon.size(); ++i) {
    const Vec2 a = polygon[i], b = polygon[(i + 1) % polygon.size()];
    const double left = (b.x - a.x) * (p.y - a.y) - (p.x - a.x) * (b.y - a.y);
    if (a.y <= p.y) {
      if (b.y > p.y && left > 0) ++w;
    } else if (b.y <= p.y && left < 0) {
      --w;
    }
  }
  return w;
}

struct PosedStick {
  std::vector<Vec2> outline;
  Vec2 object_centre{0, 0};
};

PosedStick pose_stick(const StickOptions& o, const std::vector<Affine2>& bones) {
  PosedStick posed;
  for (const Vec2 p : canonical_outline(o)) posed.outline.push_back(skin(o, bones, p));
  posed.object_centre = bones[0].apply({o.object_centre[0], o.object_centre[1]});
  return posed;
}

bool posed_inside(const StickOptions& o, const PosedStick& posed, Vec2 p) {
  if (o.with_object && std::hypot(p.x - posed.object_centre.x, p.y - posed.object_centre.y) <
                           o.object_radius)
    return true;
  return winding_number(posed.outline, p) != 0;
}

torch::Tensor to_occupancy(const std::vector<Vec2>& points,
                           const std::function<bool(Vec2)>& inside) {
  auto out = torch::empty({static_cast<int64_t>(points.size())}, torch::kUInt8);
  uint8_t* op = out.data_ptr<uint8_t>();
  for (size_t i = 0; i < points.size(); ++i) op[i] = inside(points[i]) ? 1 : 0;
  return out;
}

}  // namespace

void StickOptions::validate() const {
  FSKIN_CHECK(bone_length > 0 && half_width > 0 && half_width < bone_length,
              "stick: need 0 < half width ({}) < bone length ({})", half_width, bone_length);
  FSKIN_CHECK(outline_vertices >= 16, "stick: outline needs >= 16 vertices, got {}",
              outline_vertices);
  if (with_object) {
    FSKIN_CHECK(object_radius > 0, "stick: object radius must be positive");
    // Separate in canonical space (SNARF sec. 4.1): the disk must not touch the stick.
    const double dx = std::max({0.0, -object_centre[0], object_centre[0] - 2 * bone_length});
    const double dy = std::max(0.0, std::abs(object_centre[1]) - half_width);
    FSKIN_CHECK(std::hypot(dx, dy) > object_radius,
                "stick: the object (centre ({}, {}), radius {}) touches the stick in canonical space",
                object_centre[0], object_centre[1], object_radius);
  }
}

Skeleton stick_skeleton(const StickOptions& options) {
  options.validate();
  Skeleton skeleton;
  skeleton.joint_names = {"stick_root", "stick_joint"};
  skeleton.parents = {-1, 0};
  skeleton.rest_joints =
      torch::tensor({0.0, 0.0, 0.0, options.bone_length, 0.0, 0.0}, torch::kFloat32).reshape({2, 3});
  return skeleton;
}

torch::Tensor stick_skinning_weights(const StickOptions& options, const torch::Tensor& points) {
  options.validate();
  const auto p = planar_points(points, "stick_skinning_weights points");
  auto out = torch::empty({static_cast<int64_t>(p.size()), 2}, torch::kFloat32);
  float* op = out.data_ptr<float>();
  for (size_t i = 0; i < p.size(); ++i) {
    const auto w = weights_at(options, p[i]);
    op[2 * i] = static_cast<float>(w[0]);
    op[2 * i + 1] = static_cast<float>(w[1]);
  }
  return out;
}

torch::Tensor stick_bone_transforms(const StickOptions& options, const torch::Tensor& angles) {
  expect_shape(angles, {-1, 2}, "stick angles");
  const auto skeleton = stick_skeleton(options);
  const auto a = angles.to(torch::kFloat32);
  auto axis_angle = torch::zeros({a.size(0), 2, 3});
  axis_angle.select(2, 2).copy_(a);
  return forward_kinematics(skeleton.parents, skeleton.rest_joints, axis_angle_to_matrix(axis_angle))
      .bone_transforms;
}

torch::Tensor stick_occupancy(const StickOptions& options, const torch::Tensor& bones,
                              const torch::Tensor& points) {
  options.validate();
  const auto posed = pose_stick(options, planar_bones(bones));
  return to_occupancy(planar_points(points, "stick_occupancy points"),
                      [&](Vec2 p) { return posed_inside(options, posed, p); });
}

torch::Tensor stick_canonical_occupancy(const StickOptions& options, const torch::Tensor& points) {
  options.validate();
  return to_occupancy(planar_points(points, "stick_canonical_occupancy points"), [&](Vec2 p) {
    return in_object(options, p) || (p.x > 0 && p.x < 2 * options.bone_length &&
                                     std::abs(p.y) < options.half_width);
  });
}

torch::Tensor stick_angles(int64_t count, bool extrapolate, uint64_t seed) {
  FSKIN_CHECK(count > 0, "stick_angles: count must be positive, got {}", count);
  Rng rng(seed);
  auto out = torch::empty({count, 2}, torch::kFloat32);
  float* op = out.data_ptr<float>();
  const double deg = M_PI / 180.0;
  for (int64_t k = 0; k < 2 * count; ++k) {
    double a;
    if (extrapolate) {
      a = rng.uniform(kStickTrainDegrees, kStickExtrapolationDegrees) * deg;
      if (rng.uniform() < 0.5) a = -a;
    } else {
      a = rng.uniform(-kStickTrainDegrees, kStickTrainDegrees) * deg;
    }
    op[k] = static_cast<float>(a);
  }
  return out;
}

std::vector<DatasetFrame> make_stick_frames(const StickOptions& options, const torch::Tensor& angles,
                                            int64_t points_per_frame, double noise_sigma,
                                            uint64_t seed) {
  options.validate();
  FSKIN_CHECK(points_per_frame >= 2, "stick frames: need >= 2 points per frame");
  const auto bones = stick_bone_transforms(options, angles);
  std::vector<DatasetFrame> frames;
  for (int64_t k = 0; k < angles.size(0); ++k) {
    Rng rng = Rng::for_item(seed, static_cast<uint64_t>(k));
    const auto posed = pose_stick(options, planar_bones(bones[k]));
    // Outline pieces (polygon edges, and the circle) for boundary sampling by length.
    double outline_length = 0;
    for (size_t i = 0; i < posed.outline.size(); ++i) {
      const Vec2 a = posed.outline[i], b = posed.outline[(i + 1) % posed.outline.size()];
      outline_length += std::hypot(b.x - a.x, b.y - a.y);
    }
    const double circle_length = options.with_object ? 2 * M_PI * options.object_radius : 0.0;
    Box box;
    box.min = {INFINITY, INFINITY, 0};
    box.max = {-INFINITY, -INFINITY, 0};
    const auto grow = [&](double x, double y) {
      box.min[0] = std::min(box.min[0], x), box.max[0] = std::max(box.max[0], x);
      box.min[1] = std::min(box.min[1], y), box.max[1] = std::max(box.max[1], y);
    };
    for (const Vec2 p : posed.outline) grow(p.x, p.y);
    if (options.with_object)
      for (int s : {-1, 1}) grow(posed.object_centre.x + s * options.object_radius,
                                 posed.object_centre.y + s * options.object_radius);
    for (int a = 0; a < 2; ++a) {
      const double c = 0.5 * (box.min[a] + box.max[a]), half = 0.55 * (box.max[a] - box.min[a]);
      box.min[a] = c - half;
      box.max[a] = c + half;
    }
    const int64_t n_uniform = points_per_frame / 2, n_surface = points_per_frame - n_uniform;
    std::vector<Vec2> points;
    for (int64_t i = 0; i < n_uniform; ++i)
      points.push_back({rng.uniform(box.min[0], box.max[0]), rng.uniform(box.min[1], box.max[1])});
    for (int64_t i = 0; i < n_surface; ++i) {
      double s = rng.uniform() * (outline_length + circle_length);
      Vec2 p{0, 0};
      if (s >= outline_length) {
        const double phi = (s - outline_length) / options.object_radius;
        p = {posed.object_centre.x + options.object_radius * std::cos(phi),
             posed.object_centre.y + options.object_radius * std::sin(phi)};
      } else {
        for (size_t e = 0; e < posed.outline.size(); ++e) {
          const Vec2 a = posed.outline[e], b = posed.outline[(e + 1) % posed.outline.size()];
          const double len = std::hypot(b.x - a.x, b.y - a.y);
          if (s <= len || e + 1 == posed.outline.size()) {
            const double t = len > 0 ? std::min(1.0, s / len) : 0.0;
            p = {a.x + t * (b.x - a.x), a.y + t * (b.y - a.y)};
            break;
          }
          s -= len;
        }
      }
      points.push_back({p.x + noise_sigma * rng.normal(), p.y + noise_sigma * rng.normal()});
    }
    DatasetFrame frame;
    frame.points = torch::zeros({points_per_frame, 3});
    auto acc = frame.points.accessor<float, 2>();
    for (int64_t i = 0; i < points_per_frame; ++i) {
      acc[i][0] = static_cast<float>(points[i].x);
      acc[i][1] = static_cast<float>(points[i].y);
    }
    frame.occupancy = to_occupancy(points, [&](Vec2 p) { return posed_inside(options, posed, p); });
    frame.num_uniform = n_uniform;
    frame.bone_transforms = bones[k].contiguous();
    frame.bone_transforms_rest = frame.bone_transforms;
    frame.pose = torch::zeros({2, 3});
    frame.pose.select(1, 2).copy_(angles[k]);
    frame.trans = torch::zeros({3});
    frame.box = torch::tensor({box.min[0], box.min[1], box.min[2], box.max[0], box.max[1], box.max[2]},
                              torch::kFloat32)
                    .reshape({2, 3});
    frames.push_back(std::move(frame));
  }
  return frames;
}

}  // namespace fskin

namespace fskin {

int64_t build_stick_dataset(const StickOptions& stick, const StickDatasetOptions& options) {
  namespace fs = std::filesystem;
  stick.validate();
  FSKIN_CHECK(!options.out_dir.empty(), "stick dataset: --out is empty");
  FSKIN_CHECK(options.train > 0 && options.val >= 0 && options.test_within >= 0 &&
                  options.test_ood >= 0,
              "stick dataset: need train > 0 frames and val/test counts >= 0");
  const auto skeleton = stick_skeleton(stick);
  const std::vector<std::pair<std::string, int64_t>> splits = {
      {"train", options.train},
      {"val", options.val},
      {"test_within", options.test_within},
      {"test_ood", options.test_ood}};
  nlohmann::json split_files = nlohmann::json::object();
  int64_t total = 0;
  for (const auto& [name, count] : splits) total += count;
  ProgressBar progress("building " + options.out_dir, total, options.progress);
  for (size_t s = 0; s < splits.size(); ++s) {
    const auto& [name, count] = splits[s];
    split_files[name] = nlohmann::json::array();
    if (count == 0) continue;
    // Each split draws its own angles and points from the seed.
    Rng split_rng = Rng::for_item(options.seed, s);
    const auto angles = stick_angles(count, name == "test_ood", split_rng.next_u64());
    const auto frames = make_stick_frames(stick, angles, options.points_per_frame,
                                          options.noise_sigma, split_rng.next_u64());
    for (size_t k = 0; k < frames.size(); ++k) {
      const std::string file = fmt::format("{}_{:05d}.npz", name, k);
      frames[k].save((fs::path(options.out_dir) / file).string());
      split_files[name].push_back(file);
      progress.advance(1, file);
    }
  }
  DatasetFrame canonical;
  canonical.points = torch::zeros({0, 3});
  canonical.occupancy = torch::zeros({0}, torch::kUInt8);
  canonical.bone_transforms = torch::eye(4).expand({2, 4, 4}).contiguous();
  canonical.bone_transforms_rest = canonical.bone_transforms;
  canonical.pose = torch::zeros({2, 3});
  canonical.trans = torch::zeros({3});
  // The canonical shape's bounds (stick and object) enlarged 10%.
  double lo[2] = {0.0, -stick.half_width}, hi[2] = {2 * stick.bone_length, stick.half_width};
  for (int a = 0; stick.with_object && a < 2; ++a) {
    lo[a] = std::min(lo[a], stick.object_centre[a] - stick.object_radius);
    hi[a] = std::max(hi[a], stick.object_centre[a] + stick.object_radius);
  }
  for (int a = 0; a < 2; ++a) {
    const double centre = 0.5 * (lo[a] + hi[a]), half = 0.55 * (hi[a] - lo[a]);
    lo[a] = centre - half;
    hi[a] = centre + half;
  }
  canonical.box = torch::tensor({lo[0], lo[1], 0.0, hi[0], hi[1], 0.0}, torch::kFloat32).reshape({2, 3});
  canonical.joints = skeleton.rest_joints;
  canonical.save((fs::path(options.out_dir) / "canonical.npz").string());
  const nlohmann::json manifest = {
      {"format", "fskin-dataset"},
      {"format_version", kDatasetFormatVersion},
      {"fskin_version", FSKIN_VERSION},
      {"kind", "stick2d"},
      {"stick",
       {{"bone_length", stick.bone_length},
        {"half_width", stick.half_width},
        {"with_object", stick.with_object},
        {"object_centre", stick.object_centre},
        {"object_radius", stick.object_radius},
        {"train_degrees", kStickTrainDegrees},
        {"extrapolation_degrees", kStickExtrapolationDegrees}}},
      {"num_joints", 2},
      {"joint_names", skeleton.joint_names},
      {"parents", skeleton.parents},
      {"canonical_pose", "rest"},
      {"seed", options.seed},
      {"sampling",
       {{"uniform_points", options.points_per_frame / 2},
        {"surface_points", options.points_per_frame - options.points_per_frame / 2},
        {"box_scale", 1.1},
        {"noise_sigma", options.noise_sigma}}},
      {"frames", total},
      {"splits", split_files},
      {"complete", true},
  };
  write_file_atomically((fs::path(options.out_dir) / "manifest.json").string(),
                        manifest.dump(2) + "\n");
  return total;
}

}  // namespace fskin

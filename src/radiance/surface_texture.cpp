#include "fskin/radiance/surface_texture.h"

#include <torch/torch.h>

#include <algorithm>
#include <cmath>

#include "fskin/body/smpl_skeleton.h"
#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/export/palette.h"
#include "fskin/geometry/character_size.h"

namespace fskin {

namespace {

bool contains(const std::string& name, const char* part) { return name.find(part) != std::string::npos; }

}  // namespace

SurfaceTexture::SurfaceTexture(const torch::Tensor& canonical_vertices, const torch::Tensor& weights,
                               const std::vector<std::string>& joint_names) {
  expect_shape(canonical_vertices, {-1, 3}, "SurfaceTexture: canonical vertices");
  expect_shape(weights, {canonical_vertices.size(0), -1}, "SurfaceTexture: weights");
  const int64_t num_bones = weights.size(1);
  FSKIN_CHECK(static_cast<int64_t>(joint_names.size()) == num_bones,
              "SurfaceTexture: {} joint names for {} weight columns", joint_names.size(), num_bones);
  const auto vertices = canonical_vertices.to(torch::kFloat32).contiguous();
  const auto palette = bone_palette(num_bones).to(torch::kFloat32).div(255);
  auto colours = palette.accessor<float, 2>();
  for (int64_t j = 0; j < num_bones; ++j) {
    // Lightened towards pastel: strong enough to tell parts apart, leaving
    // room below for the patterns and seams.
    palette_.emplace_back(0.3f + 0.6f * colours[j][0], 0.3f + 0.6f * colours[j][1], 0.3f + 0.6f * colours[j][2]);
  }
  const auto lo = std::get<0>(vertices.min(0)), hi = std::get<0>(vertices.max(0));
  const auto extent = (hi - lo).contiguous();
  long_axis_ = static_cast<int>(extent.argmax().item<int64_t>());
  period_ = character_size(vertices, "SurfaceTexture") / 24.0;

  // SMPL skeletons only (body/smpl_skeleton.h: the built-in character, SMPL
  // fits); their joint names are SMPL's.
  parts_.assign(num_bones, Part::Plain);
  if (!is_smpl_skeleton(joint_names)) return;
  int64_t head = -1;
  for (int64_t j = 0; j < num_bones; ++j) {
    const auto& name = joint_names[j];
    if (name == "head") head = j, parts_[j] = Part::Head;
    else if (contains(name, "wrist") || contains(name, "hand")) parts_[j] = Part::Skin;
    else if (contains(name, "ankle") || contains(name, "foot")) parts_[j] = Part::Shoe;
  }
  const auto on_head = weights.to(torch::kFloat32).argmax(1).eq(head);
  if (on_head.sum().item<int64_t>() < 8) return;
  const auto head_vertices = vertices.index({on_head});
  const auto head_lo = std::get<0>(head_vertices.min(0)), head_hi = std::get<0>(head_vertices.max(0));
  const auto centre = ((head_lo + head_hi) / 2).contiguous(), half = ((head_hi - head_lo) / 2).contiguous();
  for (int c = 0; c < 3; ++c) {
    head_centre_[c] = centre[c].item<float>();
    head_half_[c] = std::max(half[c].item<float>(), 1e-6f);
  }
  has_face_ = true;
}

Eigen::Vector3f SurfaceTexture::albedo(const Eigen::Vector3f& p, const float* w) const {
  const auto J = static_cast<int64_t>(palette_.size());
  int64_t first = 0, second = -1;
  for (int64_t j = 1; j < J; ++j) {
    if (w[j] > w[first]) second = first, first = j;
    else if (second < 0 || w[j] > w[second]) second = j;
  }
  const Eigen::Vector3f seam(0.16f, 0.13f, 0.12f);
  if (second >= 0 && w[first] - w[second] < 0.1f) return seam;

  const Part part = parts_[first];
  if (part == Part::Shoe) return Eigen::Vector3f(0.22f, 0.18f, 0.16f);
  const Eigen::Vector3f skin(0.88f, 0.69f, 0.56f);
  if (part == Part::Skin) return skin;
  if (part == Part::Head) {
    if (!has_face_) return skin;
    // Coordinates on the head box: u across (x), v up (y), front = +z (SMPL).
    const float u = (p.x() - head_centre_.x()) / head_half_.x();
    const float v = (p.y() - head_centre_.y()) / head_half_.y();
    const float front = (p.z() - head_centre_.z()) / head_half_.z();
    if (v > 0.55f) return Eigen::Vector3f(0.30f, 0.19f, 0.11f);  // hair
    if (front > 0.3f) {
      for (const float side : {-0.35f, 0.35f}) {
        const float du = u - side, dv = v - 0.12f;
        if (du * du + dv * dv < 0.11f * 0.11f) return Eigen::Vector3f(0.08f, 0.10f, 0.22f);  // eyes
      }
      if (std::abs(u) < 0.28f && std::abs(v + 0.35f) < 0.06f) return Eigen::Vector3f(0.70f, 0.20f, 0.22f);  // mouth
    }
    return skin;
  }

  // The bone's colour with its pattern.
  const float period = static_cast<float>(period_);
  const Eigen::Vector3f base = palette_[first];
  switch (first % 3) {
    case 0: {  // stripes across the longest axis
      const float phase = p[long_axis_] / period;
      return (phase - std::floor(phase)) < 0.35f ? Eigen::Vector3f(0.55f * base) : base;
    }
    case 1: {  // 3D checker
      const auto cell = static_cast<int64_t>(std::floor(p.x() / period)) +
                        static_cast<int64_t>(std::floor(p.y() / period)) +
                        static_cast<int64_t>(std::floor(p.z() / period));
      return (cell & 1) ? Eigen::Vector3f(0.65f * base + Eigen::Vector3f::Constant(0.3f)) : base;
    }
    default: {  // dots on a lattice
      Eigen::Vector3f offset;
      for (int c = 0; c < 3; ++c) {
        const float phase = p[c] / period;
        offset[c] = phase - std::floor(phase) - 0.5f;
      }
      return offset.squaredNorm() < 0.3f * 0.3f ? Eigen::Vector3f(0.95f, 0.95f, 0.9f) : base;
    }
  }
}

torch::Tensor SurfaceTexture::vertex_colors(const torch::Tensor& canonical_vertices, const torch::Tensor& weights) const {
  expect_shape(canonical_vertices, {-1, 3}, "SurfaceTexture::vertex_colors: vertices");
  expect_shape(weights, {canonical_vertices.size(0), num_bones()}, "SurfaceTexture::vertex_colors: weights");
  const auto v = canonical_vertices.to(torch::kFloat32).contiguous();
  const auto w = weights.to(torch::kFloat32).contiguous();
  auto out = torch::empty({v.size(0), 3}, torch::kUInt8);
  const float* vp = v.data_ptr<float>();
  const float* wp = w.data_ptr<float>();
  uint8_t* op = out.data_ptr<uint8_t>();
  for (int64_t i = 0; i < v.size(0); ++i) {
    const Eigen::Vector3f c = albedo(Eigen::Map<const Eigen::Vector3f>(vp + 3 * i), wp + i * num_bones());
    for (int k = 0; k < 3; ++k) op[3 * i + k] = static_cast<uint8_t>(std::lround(255.0f * std::clamp(c[k], 0.0f, 1.0f)));
  }
  return out;
}

}  // namespace fskin

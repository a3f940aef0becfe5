#include "fskin/radiance/surface_texture.h"

#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "fskin/body/smpl_skeleton.h"
#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/export/palette.h"
#include "fskin/geometry/character_size.h"

namespace fskin {

namespace {

bool contains(const std::string& name, const char* part) { return name.find(part) != std::string::npos; }

// A lattice point's value in [-1, 1]: an integer hash (no state, the same on
// every machine).
float lattice_value(int64_t x, int64_t y, int64_t z, uint32_t octave) {
  uint64_t h = static_cast<uint64_t>(x) * 0x9E3779B97F4A7C15ull ^ static_cast<uint64_t>(y) * 0xC2B2AE3D27D4EB4Full ^
               static_cast<uint64_t>(z) * 0x165667B19E3779F9ull ^ (static_cast<uint64_t>(octave) << 32);
  h ^= h >> 33;
  h *= 0xFF51AFD7ED558CCDull;
  h ^= h >> 33;
  return static_cast<float>(h >> 40) / static_cast<float>(1 << 23) - 1.0f;
}

// Value noise at q (in lattice units): the lattice values blended trilinearly
// with smoothstep weights.
float value_noise(const Eigen::Vector3f& q, uint32_t octave) {
  const Eigen::Vector3f floor(std::floor(q.x()), std::floor(q.y()), std::floor(q.z()));
  const Eigen::Vector3f f = q - floor;
  const Eigen::Vector3f t = f.array() * f.array() * (3.0f - 2.0f * f.array());
  const auto x0 = static_cast<int64_t>(floor.x()), y0 = static_cast<int64_t>(floor.y()),
             z0 = static_cast<int64_t>(floor.z());
  float sum = 0;
  for (int corner = 0; corner < 8; ++corner) {
    const int dx = corner & 1, dy = (corner >> 1) & 1, dz = (corner >> 2) & 1;
    const float weight = (dx ? t.x() : 1 - t.x()) * (dy ? t.y() : 1 - t.y()) * (dz ? t.z() : 1 - t.z());
    sum += weight * lattice_value(x0 + dx, y0 + dy, z0 + dz, octave);
  }
  return sum;
}

// A 3 x 5 pixel font: per glyph five rows of three bits, the top row first,
// the left pixel the highest bit.
constexpr uint16_t kGlyphs[] = {
    0b111'101'101'101'111, 0b010'110'010'010'111, 0b111'001'111'100'111, 0b111'001'111'001'111,  // 0-3
    0b101'101'111'001'001, 0b111'100'111'001'111, 0b111'100'111'101'111, 0b111'001'001'001'001,  // 4-7
    0b111'101'111'101'111, 0b111'101'111'001'111, 0b010'101'111'101'101, 0b111'100'110'100'100,  // 8, 9, A, F
    0b111'010'010'010'111, 0b101'110'100'110'101, 0b110'101'101'101'101, 0b011'100'010'001'110,  // I, K, N, S
    0b110'101'110'101'101, 0b111'010'010'010'010, 0b101'101'101'101'010, 0,                      // R, T, V, space
};
// The printed text, as indices into kGlyphs: "FSKIN AVATAR 2026 ".
constexpr int kText[] = {11, 15, 13, 12, 14, 19, 10, 18, 10, 17, 10, 16, 19, 2, 0, 2, 6, 19};

}  // namespace

SurfaceTexture::SurfaceTexture(const torch::Tensor& canonical_vertices, const torch::Tensor& weights,
                               const std::vector<std::string>& joint_names, bool photographic)
    : photographic_(photographic) {
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
  const auto by_extent = std::get<1>(extent.sort(0, /*descending=*/true));
  print_axis_ = static_cast<int>(by_extent[1].item<int64_t>());
  long_low_ = lo[long_axis_].item<float>();
  long_extent_ = std::max(extent[long_axis_].item<float>(), 1e-6f);
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
  bool printable = false;
  Eigen::Vector3f colour = base_albedo(p, w, &printable);
  if (!photographic_) return colour;
  const float period = static_cast<float>(period_);
  // Print: glyph pixels period / 4 wide, cells of 4 x 6 pixels (a column and
  // a row of space), text on every fourth row of cells.
  if (printable) {
    const float pixel = period / 4;
    const auto floor_div = [](int64_t a, int64_t b) { return a >= 0 ? a / b : -((-a + b - 1) / b); };
    const auto column = static_cast<int64_t>(std::floor(p[print_axis_] / pixel));
    const auto row = static_cast<int64_t>(std::floor(-p[long_axis_] / pixel));  // rows read downwards
    const int64_t cell_row = floor_div(row, 6), cell_column = floor_div(column, 4);
    const int64_t x = column - 4 * cell_column, y = row - 6 * cell_row;
    if (cell_row - 4 * floor_div(cell_row, 4) == 0 && x < 3 && y < 5) {
      const int64_t length = static_cast<int64_t>(sizeof(kText) / sizeof(kText[0]));
      const uint16_t glyph = kGlyphs[kText[cell_column - length * floor_div(cell_column, length)]];
      if ((glyph >> (14 - (3 * y + x))) & 1) colour = Eigen::Vector3f(0.10f, 0.09f, 0.12f);
    }
  }
  // Grain of three octaves, then the gradient and tint along the longest axis.
  float grain = 0;
  const float periods[] = {period / 2, period / 5, period / 12}, amplitudes[] = {0.10f, 0.06f, 0.04f};
  for (uint32_t octave = 0; octave < 3; ++octave) grain += amplitudes[octave] * value_noise(p / periods[octave], octave);
  const float along = std::clamp((p[long_axis_] - long_low_) / long_extent_, 0.0f, 1.0f);
  const Eigen::Vector3f tint(1.0f + 0.10f * along, 1.0f, 1.0f - 0.10f * along);
  colour = (colour.array() * tint.array() * ((0.8f + 0.35f * along) * (1 + grain))).matrix();
  return colour.cwiseMax(0.0f).cwiseMin(1.0f);
}

Eigen::Vector3f SurfaceTexture::base_albedo(const Eigen::Vector3f& p, const float* w, bool* printable) const {
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
  *printable = true;
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

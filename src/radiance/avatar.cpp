#include "fskin/radiance/avatar.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/fields/preset_skinning_field.h"
#include "fskin/geometry/character_size.h"
#include "fskin/ops/ray_compositing.h"

namespace fskin {

void AvatarOptions::validate() const {
  field.validate();
  FSKIN_CHECK(skinning_grid_resolution >= 4 && skinning_grid_resolution <= 512,
              "avatar: skinning grid resolution must be within 4..512, got {}", skinning_grid_resolution);
  FSKIN_CHECK(canonical_grid_resolution >= 2 && canonical_grid_resolution <= 512,
              "avatar: canonical occupancy grid resolution must be within 2..512, got {}", canonical_grid_resolution);
  FSKIN_CHECK(posed_grid_resolution >= 2 && posed_grid_resolution <= 512,
              "avatar: posed occupancy grid resolution must be within 2..512, got {}", posed_grid_resolution);
  FSKIN_CHECK(samples_per_diagonal >= 8 && samples_per_diagonal <= 8192,
              "avatar: samples per diagonal must be within 8..8192, got {}", samples_per_diagonal);
  FSKIN_CHECK(start_bones >= 1, "avatar: start bones must be >= 1, got {}", start_bones);
  FSKIN_CHECK(skinning == "preset" || skinning == "learned", "avatar: skinning must be preset or learned, got '{}'",
              skinning);
  FSKIN_CHECK(occupancy_opacity > 0 && occupancy_opacity < 1, "avatar: occupancy opacity must be within (0, 1), got {}",
              occupancy_opacity);
}

AvatarImpl::AvatarImpl(const RiggedMesh& character, AvatarOptions options) : options_(std::move(options)) {
  options_.validate();
  const auto vertices = character.mesh.vertices.to(torch::kFloat32);
  const auto lo = std::get<0>(vertices.min(0)), hi = std::get<0>(vertices.max(0));
  const double grow = 0.05 * (hi - lo).max().item<double>();
  for (int c = 0; c < 3; ++c) {
    lower_[c] = lo[c].item<double>() - grow;
    upper_[c] = hi[c].item<double>() + grow;
  }
  const auto preset = diffuse_weights_to_grid(
      vertices, character.weights, VoxelBox::fit(vertices.to(torch::kFloat64), options_.skinning_grid_resolution));
  preset_grid_ = preset->grid_weights().to(torch::kFloat32);
  skinning_ = preset;
  if (options_.skinning == "learned") {
    skinning_logits_ = register_parameter("skinning_logits", torch::log(preset_grid_.clamp_min(1e-3)));
    learned_skinning_ = std::make_shared<CallerGridSkinningField>(
        torch::softmax(skinning_logits_.detach(), -1), preset->box());
    skinning_ = learned_skinning_;
  }
  auto deformer_options = DeformerOptions::fast_snarf().scaled(length_unit(vertices, "avatar: canonical vertices"));
  deformer_options.start_bones =
      StartBones::automatic(std::min<int64_t>(options_.start_bones, character.num_joints()));
  deformer_ = std::make_unique<FastSnarfDeformer>(skinning_, deformer_options);
  field_ = register_module("field", RadianceField(options_.field, lower_, upper_));
  occupancy_ = register_buffer(
      "canonical_occupancy",
      torch::ones({options_.canonical_grid_resolution, options_.canonical_grid_resolution,
                   options_.canonical_grid_resolution},
                  torch::kUInt8));
}

OccupancyGrid AvatarImpl::canonical_grid() const {
  OccupancyGrid grid;
  grid.lower = lower_;
  grid.upper = upper_;
  grid.occupied = occupancy_.to(torch::kBool);
  return grid;
}

void AvatarImpl::reset_canonical_occupancy() { occupancy_.fill_(1); }

void AvatarImpl::refresh_skinning() {
  if (!learned_skinning_) return;
  const auto grid = torch::softmax(skinning_logits_, -1);
  learned_skinning_->set_grid(torch::GradMode::is_enabled() ? grid : grid.detach());
}

torch::Tensor AvatarImpl::skinning_prior() {
  if (!learned_skinning_) return torch::zeros({});
  // The grid the deformer reads (with this step's graph after refresh_skinning), not a second softmax.
  return (learned_skinning_->grid_weights() - preset_grid_).pow(2).sum(-1).mean();
}

void AvatarImpl::update_canonical_occupancy() {
  torch::NoGradGuard no_grad;
  const auto grid = canonical_grid();
  const int64_t R = grid.resolution();
  auto centres = grid.cell_centres();
  // One jittered point per cell: over many updates every part of a cell is seen.
  std::array<double, 3> cell;
  double diagonal = 0;
  for (int c = 0; c < 3; ++c) {
    cell[c] = (upper_[c] - lower_[c]) / R;
    diagonal += (upper_[c] - lower_[c]) * (upper_[c] - lower_[c]);
  }
  const auto cell_size = torch::tensor({cell[0], cell[1], cell[2]}, torch::kFloat32);
  centres = centres + (torch::rand_like(centres) - 0.5) * cell_size;
  // The step of a ray through a posed box about as large as the canonical one.
  const double step = std::sqrt(diagonal) / static_cast<double>(options_.samples_per_diagonal);
  const auto device = field_->table().device();
  std::vector<torch::Tensor> occupied;
  for (int64_t begin = 0; begin < centres.size(0); begin += 1 << 16) {
    const auto chunk = centres.slice(0, begin, std::min<int64_t>(begin + (1 << 16), centres.size(0))).to(device);
    const auto sigma = field_->density(chunk);
    occupied.push_back((1 - torch::exp(-sigma * step) > options_.occupancy_opacity).cpu());
  }
  OccupancyGrid marked = grid;
  marked.occupied = torch::cat(occupied).reshape({R, R, R});
  occupancy_.copy_(marked.dilated().occupied.to(torch::kUInt8));
}

PosedFrame AvatarImpl::pose(const torch::Tensor& bones) {
  torch::NoGradGuard no_grad;
  expect_shape(bones, {skinning_->num_bones(), 4, 4}, "avatar: bone transforms");
  expect_finite(bones, "avatar: bone transforms");
  PosedFrame frame;
  frame.bones = bones.to(torch::kFloat32).cpu().contiguous();
  const auto box = posed_bounds(skinning_->box().voxel_centres(), skinning_->grid_weights(), frame.bones);
  auto grid = OccupancyGrid::filled(box[0], box[1], options_.posed_grid_resolution, false);
  const auto centres = grid.cell_centres();
  const auto canonical = canonical_grid();
  std::vector<torch::Tensor> hits;
  for (int64_t begin = 0; begin < centres.size(0); begin += 1 << 16) {
    const auto chunk = centres.slice(0, begin, std::min<int64_t>(begin + (1 << 16), centres.size(0)));
    const auto found = deformer_->forward(chunk.unsqueeze(0), frame.bones.unsqueeze(0));
    hits.push_back((found.valid[0] & canonical.lookup(found.x_canonical[0])).any(1));
  }
  const int64_t R = grid.resolution();
  grid.occupied = torch::cat(hits).reshape({R, R, R});
  frame.grid = grid.dilated();
  const auto cells = frame.grid.occupied.nonzero();  // [K, 3] (z, y, x)
  if (cells.size(0) > 0) {
    const auto first = std::get<0>(cells.min(0)), last = std::get<0>(cells.max(0));
    for (int c = 0; c < 3; ++c) {
      const double size = (box[1][c] - box[0][c]) / static_cast<double>(R);
      frame.lower[c] = box[0][c] + size * static_cast<double>(first[2 - c].item<int64_t>());
      frame.upper[c] = box[0][c] + size * static_cast<double>(last[2 - c].item<int64_t>() + 1);
    }
  }
  double diagonal = 0;
  for (int c = 0; c < 3; ++c) diagonal += (box[1][c] - box[0][c]) * (box[1][c] - box[0][c]);
  frame.step = std::sqrt(diagonal) / static_cast<double>(options_.samples_per_diagonal);
  return frame;
}

RayRender AvatarImpl::render_rays(const PosedFrame& frame, const torch::Tensor& origins,
                                  const torch::Tensor& directions, const torch::Tensor& background, bool jitter) {
  expect_shape(origins, {-1, 3}, "avatar: ray origins");
  const int64_t R = origins.size(0);
  expect_shape(directions, {R, 3}, "avatar: ray directions");
  expect_shape(background, {R, 3}, "avatar: ray backgrounds");
  const auto o = origins.to(torch::kFloat32).cpu(), d = directions.to(torch::kFloat32).cpu();
  const auto& g = frame.grid;
  // Slab intersection with the box of the occupied cells.
  const auto lo = torch::tensor({frame.lower[0], frame.lower[1], frame.lower[2]}, torch::kFloat32);
  const auto hi = torch::tensor({frame.upper[0], frame.upper[1], frame.upper[2]}, torch::kFloat32);
  const auto inverse = 1.0 / torch::where(d.abs() < 1e-12, torch::full_like(d, 1e-12), d);
  const auto ta = (lo - o) * inverse, tb = (hi - o) * inverse;
  const auto t_near = std::get<0>(torch::minimum(ta, tb).max(1)).clamp_min(0);
  const auto t_far = std::get<0>(torch::maximum(ta, tb).min(1));
  const auto background_f = background.to(torch::kFloat32);
  RayRender out;
  // Coarse pass at half the smallest cell: the span of occupied cells along
  // each ray, so that fine samples are only taken there (rays that meet no
  // occupied cell take none).
  double cell = std::numeric_limits<double>::infinity();
  for (int c = 0; c < 3; ++c) cell = std::min(cell, (g.upper[c] - g.lower[c]) / static_cast<double>(g.resolution()));
  const double coarse_step = 0.5 * cell;
  const auto hit = t_far > t_near;
  const auto span = torch::where(hit, t_far - t_near, torch::zeros_like(t_far));
  const int64_t coarse_count = R == 0 ? 0 : static_cast<int64_t>(std::ceil(span.max().item<double>() / coarse_step));
  torch::Tensor active;  // rays with occupied cells
  torch::Tensor t_begin, t_end;
  if (coarse_count > 0) {
    const auto tc = t_near.unsqueeze(1) + (torch::arange(coarse_count, torch::kFloat32).unsqueeze(0) + 0.5) * coarse_step;
    const auto occupied_coarse =
        (tc < t_far.unsqueeze(1)) & hit.unsqueeze(1) & g.lookup(o.unsqueeze(1) + tc.unsqueeze(2) * d.unsqueeze(1));
    active = occupied_coarse.any(1).nonzero().reshape({-1});
    const auto inf = std::numeric_limits<float>::infinity();
    const auto first = std::get<0>(torch::where(occupied_coarse, tc, torch::full_like(tc, inf)).min(1));
    const auto last = std::get<0>(torch::where(occupied_coarse, tc, torch::full_like(tc, -inf)).max(1));
    t_begin = torch::maximum(t_near, first - coarse_step).index_select(0, active);
    t_end = torch::minimum(t_far, last + coarse_step).index_select(0, active);
  }
  const int64_t A = active.defined() ? active.size(0) : 0;
  const double step = frame.step;
  const int64_t S = A == 0 ? 0 : static_cast<int64_t>(std::ceil((t_end - t_begin).max().item<double>() / step));
  const auto device = field_->table().device();
  if (S == 0) {
    out.color = background_f.to(device).clone();
    out.opacity = torch::zeros({R}, out.color.options());
    return out;
  }
  const auto oa = o.index_select(0, active), da = d.index_select(0, active);
  const auto offset = jitter ? torch::rand({A, 1}) : torch::full({A, 1}, 0.5);
  const auto t = t_begin.unsqueeze(1) + (torch::arange(S, torch::kFloat32).unsqueeze(0) + offset) * step;
  const auto in_range = t < t_end.unsqueeze(1);
  const auto points = oa.unsqueeze(1) + t.unsqueeze(2) * da.unsqueeze(1);  // [A, S, 3]
  const auto occupied = in_range & g.lookup(points);
  const auto posed = points.index({occupied});  // [M, 3]
  const int64_t M = posed.size(0);
  out.samples = M;

  torch::Tensor sigma_dense = torch::zeros({A, S}, torch::TensorOptions(device));
  torch::Tensor rgb_dense = torch::zeros({A, S, 3}, torch::TensorOptions(device));
  if (M > 0) {
    DeformerOutput found;
    if (frame.bones.requires_grad() || (learned_skinning_ && learned_skinning_->requires_grad())) {
      // Bones being refined (radiance/pose_correction.h) or skinning being
      // learned: the correspondences carry the implicit gradient w.r.t. the
      // bones and the weight grid (Fast-SNARF eq. 16-17).
      found = deformer_->forward(posed.unsqueeze(0), frame.bones.unsqueeze(0));
    } else {
      // Preset weights and given bones: the correspondences carry no gradient.
      torch::NoGradGuard no_grad;
      found = deformer_->forward(posed.unsqueeze(0), frame.bones.unsqueeze(0));
    }
    const int64_t I = found.valid.size(2);
    const auto valid = found.valid[0].reshape({-1}).to(device);
    const auto candidates = found.x_canonical[0].reshape({-1, 3}).to(device).index({valid});
    torch::Tensor rotations;
    if (field_->options().lambert()) {
      // Each candidate's blended bone rotation sum_j w_j(x) R_j (LBS of its normal).
      const auto weights = skinning_->weights(candidates.to(torch::kCPU)).to(device);
      const auto R = frame.bones.narrow(1, 0, 3).narrow(2, 0, 3).to(device).reshape({-1, 9});
      rotations = torch::matmul(weights, R).reshape({-1, 3, 3});
    }
    const auto sample = field_->forward(candidates, rotations, frame.appearance);
    const auto sigma_all = torch::zeros({M * I}, sample.sigma.options()).index_put({valid}, sample.sigma).reshape({M, I});
    const auto rgb_all =
        torch::zeros({M * I, 3}, sample.rgb.options()).index_put({valid}, sample.rgb).reshape({M, I, 3});
    // The candidate of largest density (Fast-SNARF sec. 7); none valid: density 0.
    const auto pick = torch::where(valid.reshape({M, I}), sigma_all.detach(), torch::full_like(sigma_all, -1))
                          .argmax(1, /*keepdim=*/true);
    const auto sigma = sigma_all.gather(1, pick).squeeze(1);
    const auto rgb = rgb_all.gather(1, pick.unsqueeze(2).expand({M, 1, 3})).squeeze(1);
    const auto mask = occupied.to(device);
    sigma_dense = sigma_dense.index_put({mask}, sigma);
    rgb_dense = rgb_dense.index_put({mask}, rgb);
  }
  const auto delta = occupied.to(torch::kFloat32).mul(static_cast<float>(step)).to(device);
  const auto background_device = background_f.to(device);
  const auto active_device = active.to(device);
  const auto [color, opacity] =
      composite_rays(sigma_dense, rgb_dense, delta, background_device.index_select(0, active_device));
  // Rays without samples show the background.
  out.color = background_device.index_put({active_device}, color);
  out.opacity = torch::zeros({R}, color.options()).index_put({active_device}, opacity);
  return out;
}

std::pair<torch::Tensor, torch::Tensor> AvatarImpl::render_image(const PosedFrame& frame, const PinholeCamera& camera,
                                                                 const std::array<double, 3>& background,
                                                                 int64_t rays_per_chunk) {
  torch::NoGradGuard no_grad;
  camera.validate("avatar: camera");
  FSKIN_CHECK(rays_per_chunk > 0, "avatar: rays per chunk must be positive, got {}", rays_per_chunk);
  const auto pixels = pixel_centres(camera.width, camera.height);
  const auto [origins, directions] = camera_rays(camera, pixels);
  const auto back = torch::tensor({background[0], background[1], background[2]}, torch::kFloat32);
  std::vector<torch::Tensor> colors, opacities;
  for (int64_t begin = 0; begin < pixels.size(0); begin += rays_per_chunk) {
    const int64_t end = std::min<int64_t>(begin + rays_per_chunk, pixels.size(0));
    const auto rendered = render_rays(frame, origins.slice(0, begin, end), directions.slice(0, begin, end),
                                      back.expand({end - begin, 3}), /*jitter=*/false);
    colors.push_back(rendered.color.cpu());
    opacities.push_back(rendered.opacity.cpu());
  }
  return {torch::cat(colors).reshape({camera.height, camera.width, 3}),
          torch::cat(opacities).reshape({camera.height, camera.width})};
}

}  // namespace fskin

// rasterize_gaussians as the dispatcher op fskin::rasterize_gaussians (schema,
// CPU / CUDA kernels, Autograd; ops/common/dispatcher.h): validates the
// inputs, bins the Gaussians into tiles, fills the raw launch arguments and
// wires forward and backward into autograd. Also the dense LibTorch reference.
#include "fskin/ops/gaussian_rasterization.h"

#include <torch/library.h>
#include <torch/torch.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "ops/common/dispatcher.h"
#include "ops/common/run_on_device.h"
#include "ops/gaussian_rasterization/gaussian_rasterization_kernel.h"

namespace fskin {
namespace {

namespace gr = gaussian_rasterization;

constexpr int64_t kMaxImageSide = 16384;

void check_inputs(const torch::Tensor& means2d, const torch::Tensor& conics, const torch::Tensor& colors,
                  const torch::Tensor& opacities, const torch::Tensor& depths, const torch::Tensor& radii,
                  const torch::Tensor& background, int64_t width, int64_t height) {
  expect_shape(means2d, {-1, 2}, "rasterize_gaussians: means2d");
  const int64_t n = means2d.size(0);
  expect_shape(conics, {n, 3}, "rasterize_gaussians: conics");
  expect_shape(colors, {n, -1}, "rasterize_gaussians: colors");
  const int64_t channels = colors.size(1);
  FSKIN_CHECK(channels >= 1 && channels <= gr::kMaxChannels,
              "rasterize_gaussians: colors must have 1 to {} channels, got {}", gr::kMaxChannels, channels);
  expect_shape(opacities, {n}, "rasterize_gaussians: opacities");
  expect_shape(depths, {n}, "rasterize_gaussians: depths");
  expect_shape(radii, {n}, "rasterize_gaussians: radii");
  expect_shape(background, {channels}, "rasterize_gaussians: background");
  FSKIN_CHECK(width >= 1 && height >= 1 && width <= kMaxImageSide && height <= kMaxImageSide,
              "rasterize_gaussians: the picture must be 1 to {} pixels a side, got {} x {}", kMaxImageSide, width,
              height);
  const auto dtype = means2d.scalar_type();
  FSKIN_CHECK(dtype == torch::kFloat32 || dtype == torch::kFloat64,
              "rasterize_gaussians: means2d must be float32 or float64, got {}", c10::toString(dtype));
  for (const auto* t : {&conics, &colors, &opacities, &depths, &radii, &background}) {
    FSKIN_CHECK(t->scalar_type() == dtype,
                "rasterize_gaussians: means2d, conics, colors, opacities, depths, radii and background must "
                "share one dtype");
    FSKIN_CHECK(t->device() == means2d.device(), "rasterize_gaussians: inputs on different devices");
  }
}

struct Tiles {
  int64_t x, y;
};

Tiles tiles_for(int64_t width, int64_t height) {
  return {(width + gr::kTileSize - 1) / gr::kTileSize, (height + gr::kTileSize - 1) / gr::kTileSize};
}

// Per Gaussian, the tiles [x0, x1) x [y0, y1) holding the pixel centres
// within `radii` of its mean (int64; empty for radius <= 0 or non-finite input).
std::array<torch::Tensor, 4> tile_rectangles(const torch::Tensor& means2d, const torch::Tensor& radii, Tiles tiles) {
  const auto u = means2d.select(1, 0), v = means2d.select(1, 1);
  const auto drawn = (radii > 0) & torch::isfinite(u) & torch::isfinite(v) & torch::isfinite(radii);
  const auto zero = torch::zeros_like(radii);
  const auto r = torch::where(drawn, radii, zero);
  const auto uu = torch::where(drawn, u, zero), vv = torch::where(drawn, v, zero);
  const double side = gr::kTileSize;
  const auto clamp = [](const torch::Tensor& t, int64_t high) {
    return t.clamp(0, static_cast<double>(high)).to(torch::kInt64);
  };
  auto x0 = clamp(torch::floor((uu - r) / side), tiles.x), x1 = clamp(torch::floor((uu + r) / side) + 1, tiles.x);
  auto y0 = clamp(torch::floor((vv - r) / side), tiles.y), y1 = clamp(torch::floor((vv + r) / side) + 1, tiles.y);
  x1 = torch::where(drawn, x1, x0);
  y1 = torch::where(drawn, y1, y0);
  return {x0, x1, y0, y1};
}

struct Inputs {
  torch::Tensor means2d, conics, colors, opacities, depths, radii, background;  // contiguous
};

// The tile lists: every (tile, Gaussian) pair a Gaussian's rectangle covers,
// sorted by tile and then by depth (a stable depth order, so ties keep the
// Gaussians' order), with each tile's range of entries.
struct TileBins {
  torch::Tensor gaussians;  // [M] int64
  torch::Tensor ranges;     // [tiles + 1] int64
};

TileBins bin_gaussians_with_ops(const torch::Tensor& means2d, const torch::Tensor& depths,
                                const torch::Tensor& radii, Tiles tiles) {
  const int64_t n = means2d.size(0);
  const auto index_options = means2d.options().dtype(torch::kInt64);
  const auto [x0, x1, y0, y1] = tile_rectangles(means2d, radii, tiles);
  const auto columns = (x1 - x0).clamp_min(0), rows = (y1 - y0).clamp_min(0);
  const auto counts = columns * rows;
  const auto gaussian = torch::repeat_interleave(counts);  // [M]
  const int64_t entries = gaussian.size(0);
  const auto first_entry = torch::cumsum(counts, 0) - counts;
  const auto k = torch::arange(entries, index_options) - first_entry.index_select(0, gaussian);
  const auto width_of = columns.index_select(0, gaussian);
  const auto tile_x = x0.index_select(0, gaussian) + torch::remainder(k, width_of);
  const auto tile_y = y0.index_select(0, gaussian) + k.div(width_of, "trunc");
  const auto tile = tile_y * tiles.x + tile_x;
  const auto depth_order = std::get<1>(torch::sort(depths, /*stable=*/true, 0, false));
  const auto depth_rank = torch::empty_like(depth_order).scatter_(0, depth_order, torch::arange(n, index_options));
  const auto key = tile * std::max<int64_t>(n, 1) + depth_rank.index_select(0, gaussian);
  const auto order = std::get<1>(torch::sort(key, /*stable=*/true, 0, false));
  TileBins bins;
  bins.gaussians = gaussian.index_select(0, order).contiguous();
  const auto per_tile = torch::bincount(tile, {}, tiles.x * tiles.y);
  bins.ranges = torch::cat({torch::zeros({1}, index_options), torch::cumsum(per_tile, 0)}).contiguous();
  return bins;
}

// The same tile lists on the CPU by a counting sort over the tiles: O(pairs)
// instead of sorting every (tile, Gaussian) pair, which with the ops above
// took 8 % of a pose-fitting step (torch.profiler, 2 threads). The Gaussians'
// depth order is the ops' (a stable sort, NaN last); each tile's list is
// filled in that order, so the lists are equal entry for entry. The CUDA
// path keeps the ops: a GPU sorts the pairs in parallel.
template <typename T>
TileBins bin_gaussians_cpu(const Inputs& in, Tiles tiles) {
  const int64_t n = in.means2d.size(0), tile_count = tiles.x * tiles.y;
  const T* means = in.means2d.data_ptr<T>();
  const T* radii = in.radii.data_ptr<T>();
  // The rectangles as tile_rectangles computes them, in T as its ops do.
  std::vector<std::array<int64_t, 4>> rectangles(static_cast<size_t>(n));
  std::vector<int64_t> ranges(static_cast<size_t>(tile_count + 1), 0);
  const T side = gr::kTileSize;
  const auto clamp = [](T t, int64_t high) {
    return static_cast<int64_t>(std::min(std::max(t, T(0)), static_cast<T>(high)));
  };
  for (int64_t g = 0; g < n; ++g) {
    const T u = means[2 * g], v = means[2 * g + 1], r = radii[g];
    auto& [x0, x1, y0, y1] = rectangles[static_cast<size_t>(g)];
    if (!(r > 0 && std::isfinite(u) && std::isfinite(v) && std::isfinite(r))) {
      x0 = x1 = y0 = y1 = 0;
      continue;
    }
    x0 = clamp(std::floor((u - r) / side), tiles.x);
    x1 = clamp(std::floor((u + r) / side) + 1, tiles.x);
    y0 = clamp(std::floor((v - r) / side), tiles.y);
    y1 = clamp(std::floor((v + r) / side) + 1, tiles.y);
    for (int64_t y = y0; y < y1; ++y)
      for (int64_t x = x0; x < x1; ++x) ++ranges[static_cast<size_t>(y * tiles.x + x + 1)];
  }
  for (int64_t t = 0; t < tile_count; ++t) ranges[t + 1] += ranges[t];
  const auto depth_order = std::get<1>(torch::sort(in.depths, /*stable=*/true, 0, false)).contiguous();
  const int64_t* order = depth_order.data_ptr<int64_t>();
  auto gaussians = torch::empty({ranges.back()}, torch::kInt64);
  int64_t* out = gaussians.data_ptr<int64_t>();
  std::vector<int64_t> next(ranges.begin(), ranges.end() - 1);
  for (int64_t k = 0; k < n; ++k) {
    const int64_t g = order[k];
    const auto& [x0, x1, y0, y1] = rectangles[static_cast<size_t>(g)];
    for (int64_t y = y0; y < y1; ++y)
      for (int64_t x = x0; x < x1; ++x) out[next[static_cast<size_t>(y * tiles.x + x)]++] = g;
  }
  return {gaussians, torch::tensor(ranges, torch::kInt64)};
}

TileBins bin_gaussians(const Inputs& in, Tiles tiles) {
  if (in.means2d.is_cuda()) return bin_gaussians_with_ops(in.means2d, in.depths, in.radii, tiles);
  TileBins bins;
  AT_DISPATCH_FLOATING_TYPES(in.means2d.scalar_type(), "bin_gaussians",
                             [&] { bins = bin_gaussians_cpu<scalar_t>(in, tiles); });
  return bins;
}

Inputs contiguous(const torch::Tensor& means2d, const torch::Tensor& conics, const torch::Tensor& colors,
                  const torch::Tensor& opacities, const torch::Tensor& depths, const torch::Tensor& radii,
                  const torch::Tensor& background) {
  return {means2d.contiguous(),   conics.contiguous(), colors.contiguous(),    opacities.contiguous(),
          depths.contiguous(),    radii.contiguous(),  background.contiguous()};
}

template <typename T>
gr::RasterLaunch<T> launch_for(const Inputs& in, const TileBins& bins, int64_t width, int64_t height) {
  const Tiles tiles = tiles_for(width, height);
  gr::RasterLaunch<T> a{};
  a.means2d = in.means2d.data_ptr<T>();
  a.conics = in.conics.data_ptr<T>();
  a.colors = in.colors.data_ptr<T>();
  a.opacities = in.opacities.data_ptr<T>();
  a.background = in.background.data_ptr<T>();
  a.tile_gaussians = bins.gaussians.data_ptr<int64_t>();
  a.tile_ranges = bins.ranges.data_ptr<int64_t>();
  a.gaussians = in.means2d.size(0);
  a.channels = static_cast<int>(in.colors.size(1));
  a.width = static_cast<int>(width);
  a.height = static_cast<int>(height);
  a.tiles_x = static_cast<int>(tiles.x);
  a.tiles_y = static_cast<int>(tiles.y);
  return a;
}

using RasterizeSignature = std::tuple<torch::Tensor, torch::Tensor>(
    const torch::Tensor&, const torch::Tensor&, const torch::Tensor&, const torch::Tensor&, const torch::Tensor&,
    const torch::Tensor&, const torch::Tensor&, int64_t, int64_t);
using RasterizeForwardSignature = std::tuple<torch::Tensor, torch::Tensor, torch::Tensor, torch::Tensor>(
    const torch::Tensor&, const torch::Tensor&, const torch::Tensor&, const torch::Tensor&, const torch::Tensor&,
    const torch::Tensor&, const torch::Tensor&, int64_t, int64_t);
using RasterizeBackwardSignature =
    std::tuple<torch::Tensor, torch::Tensor, torch::Tensor, torch::Tensor, torch::Tensor>(
        const torch::Tensor&, const c10::optional<torch::Tensor>&, const torch::Tensor&, const torch::Tensor&,
        const torch::Tensor&, const torch::Tensor&, const torch::Tensor&, const torch::Tensor&,
        const torch::Tensor&, const torch::Tensor&, const torch::Tensor&, const torch::Tensor&,
        const torch::Tensor&, int64_t, int64_t, std::array<bool, 5>);

// Tile lists handed from the forward to the backward: checked, as the
// backward op can be called on its own.
TileBins given_bins(const torch::Tensor& tile_gaussians, const torch::Tensor& tile_ranges, int64_t gaussians,
                    int64_t width, int64_t height, const torch::Device& device) {
  const Tiles tiles = tiles_for(width, height);
  expect_shape(tile_gaussians, {-1}, "rasterize_gaussians backward: tile_gaussians");
  expect_shape(tile_ranges, {tiles.x * tiles.y + 1}, "rasterize_gaussians backward: tile_ranges");
  for (const auto* t : {&tile_gaussians, &tile_ranges}) {
    FSKIN_CHECK(t->scalar_type() == torch::kInt64 && t->device() == device,
                "rasterize_gaussians backward: the tile lists must be int64 on the inputs' device");
  }
  TileBins bins{tile_gaussians.contiguous(), tile_ranges.contiguous()};
  // The kernels index with them: a list from elsewhere must stay within its arrays.
  const auto ranges = bins.ranges.cpu();
  const auto* r = ranges.data_ptr<int64_t>();
  const int64_t entries = bins.gaussians.size(0);
  bool ordered = r[0] == 0 && r[tiles.x * tiles.y] == entries;
  for (int64_t t = 0; ordered && t < tiles.x * tiles.y; ++t) ordered = r[t] <= r[t + 1];
  FSKIN_CHECK(ordered, "rasterize_gaussians backward: tile_ranges must rise from 0 to the number of tile entries");
  if (entries > 0) {
    const auto [low, high] = torch::aminmax(bins.gaussians);
    FSKIN_CHECK(low.item<int64_t>() >= 0 && high.item<int64_t>() < gaussians,
                "rasterize_gaussians backward: tile_gaussians must index the {} Gaussians", gaussians);
  }
  return bins;
}

}  // namespace

// The CPU and CUDA keys' kernel of the forward (one function: the devices
// share the per-pixel core and its launch arguments; run_on_device picks the
// launch), with the tile lists it drew from, which the backward reuses.
std::tuple<torch::Tensor, torch::Tensor, torch::Tensor, torch::Tensor> rasterize_gaussians_forward_kernel(
    const torch::Tensor& means2d, const torch::Tensor& conics, const torch::Tensor& colors,
    const torch::Tensor& opacities, const torch::Tensor& depths, const torch::Tensor& radii,
    const torch::Tensor& background, int64_t width, int64_t height) {
  check_inputs(means2d, conics, colors, opacities, depths, radii, background, width, height);
  const Inputs in = contiguous(means2d, conics, colors, opacities, depths, radii, background);
  const TileBins bins = bin_gaussians(in, tiles_for(width, height));
  auto image = torch::empty({height, width, in.colors.size(1)}, in.means2d.options());
  auto alpha = torch::empty({height, width}, in.means2d.options());
  AT_DISPATCH_FLOATING_TYPES(in.means2d.scalar_type(), "rasterize_gaussians", [&] {
    auto a = launch_for<scalar_t>(in, bins, width, height);
    a.image = image.data_ptr<scalar_t>();
    a.alpha = alpha.data_ptr<scalar_t>();
    run_on_device(
        in.means2d, "rasterize_gaussians", [&] { gr::rasterize_cpu(a, false); },
        [&](void* stream) { gr::rasterize_cuda(a, false, stream); });
  });
  return {image, alpha, bins.gaussians, bins.ranges};
}

std::tuple<torch::Tensor, torch::Tensor> rasterize_gaussians_kernel(
    const torch::Tensor& means2d, const torch::Tensor& conics, const torch::Tensor& colors,
    const torch::Tensor& opacities, const torch::Tensor& depths, const torch::Tensor& radii,
    const torch::Tensor& background, int64_t width, int64_t height) {
  const auto out =
      rasterize_gaussians_forward_kernel(means2d, conics, colors, opacities, depths, radii, background, width, height);
  return {std::get<0>(out), std::get<1>(out)};
}

namespace {

// The analytic backward, given the forward's image, alpha and tile lists; output_mask
// says which of (means2d, conics, colors, opacities, background) need a
// gradient, the others come back undefined.
std::tuple<torch::Tensor, torch::Tensor, torch::Tensor, torch::Tensor, torch::Tensor>
rasterize_gaussians_backward_kernel(const torch::Tensor& grad_image, const c10::optional<torch::Tensor>& grad_alpha,
                                    const torch::Tensor& image, const torch::Tensor& alpha,
                                    const torch::Tensor& tile_gaussians, const torch::Tensor& tile_ranges,
                                    const torch::Tensor& means2d, const torch::Tensor& conics,
                                    const torch::Tensor& colors, const torch::Tensor& opacities,
                                    const torch::Tensor& depths, const torch::Tensor& radii,
                                    const torch::Tensor& background, int64_t width, int64_t height,
                                    std::array<bool, 5> output_mask) {
  check_inputs(means2d, conics, colors, opacities, depths, radii, background, width, height);
  const Inputs in = contiguous(means2d, conics, colors, opacities, depths, radii, background);
  const int64_t channels = in.colors.size(1), n = in.means2d.size(0);
  expect_shape(grad_image, {height, width, channels}, "rasterize_gaussians backward: grad_image");
  expect_shape(image, {height, width, channels}, "rasterize_gaussians backward: image");
  expect_shape(alpha, {height, width}, "rasterize_gaussians backward: alpha");
  const auto options = in.means2d.options();
  const auto forward_image = image.to(options).contiguous(), forward_alpha = alpha.to(options).contiguous();
  const auto gi = grad_image.to(options).contiguous();
  torch::Tensor ga;
  if (grad_alpha && grad_alpha->defined()) {
    expect_shape(*grad_alpha, {height, width}, "rasterize_gaussians backward: grad_alpha");
    ga = grad_alpha->to(options).contiguous();
  }
  const TileBins bins = given_bins(tile_gaussians, tile_ranges, n, width, height, in.means2d.device());
  const int64_t columns = gr::gradient_columns(static_cast<int>(channels));
  const bool per_entry = in.means2d.is_cpu();
  auto rows = torch::zeros({per_entry ? bins.gaussians.size(0) : n, columns}, options);
  auto background_per_pixel = torch::zeros({height, width, channels}, options);
  AT_DISPATCH_FLOATING_TYPES(in.means2d.scalar_type(), "rasterize_gaussians backward", [&] {
    auto a = launch_for<scalar_t>(in, bins, width, height);
    a.image = forward_image.data_ptr<scalar_t>();  // read only
    a.alpha = forward_alpha.data_ptr<scalar_t>();
    a.grad_image = gi.data_ptr<scalar_t>();
    a.grad_alpha = ga.defined() ? ga.data_ptr<scalar_t>() : nullptr;
    a.grad_background = background_per_pixel.data_ptr<scalar_t>();
    a.grad_rows = rows.data_ptr<scalar_t>();
    run_on_device(
        in.means2d, "rasterize_gaussians backward", [&] { gr::rasterize_cpu(a, true); },
        [&](void* stream) { gr::rasterize_cuda(a, true, stream); });
  });
  // CPU rows are per tile entry: summed per Gaussian in entry order.
  const auto per_gaussian = per_entry ? torch::zeros({n, columns}, options).index_add_(0, bins.gaussians, rows) : rows;
  const auto column_block = [&](int64_t first, int64_t count) {
    return per_gaussian.narrow(1, first, count).contiguous();
  };
  torch::Tensor g_means, g_conics, g_colors, g_opacities, g_background;
  if (output_mask[0]) g_means = column_block(gr::kGradMean, 2);
  if (output_mask[1]) g_conics = column_block(gr::kGradConic, 3);
  if (output_mask[2]) g_colors = column_block(gr::kGradColor, channels);
  if (output_mask[3]) g_opacities = column_block(gr::kGradOpacity, 1).view({n});
  if (output_mask[4]) g_background = background_per_pixel.view({-1, channels}).sum(0);
  return {g_means, g_conics, g_colors, g_opacities, g_background};
}

// The Autograd key: records the graph and calls the device kernels below it
// (as torchvision's ops/autograd/ do), so the backward runs the op's own kernel.
class RasterizeFunction : public torch::autograd::Function<RasterizeFunction> {
 public:
  static torch::autograd::tensor_list forward(torch::autograd::AutogradContext* ctx, const torch::Tensor& means2d,
                                              const torch::Tensor& conics, const torch::Tensor& colors,
                                              const torch::Tensor& opacities, const torch::Tensor& depths,
                                              const torch::Tensor& radii, const torch::Tensor& background,
                                              int64_t width, int64_t height) {
    ctx->saved_data["width"] = width;
    ctx->saved_data["height"] = height;
    at::AutoDispatchBelowADInplaceOrView below_autograd;
    static const auto op = fskin_operator<RasterizeForwardSignature>("fskin::_rasterize_gaussians_forward");
    const auto [image, alpha, tile_gaussians, tile_ranges] =
        op.call(means2d, conics, colors, opacities, depths, radii, background, width, height);
    // The backward takes each pixel's colour and transmittance from the
    // outputs and walks the same tile lists.
    ctx->save_for_backward(
        {means2d, conics, colors, opacities, depths, radii, background, image, alpha, tile_gaussians, tile_ranges});
    return {image, alpha};
  }

  static torch::autograd::tensor_list backward(torch::autograd::AutogradContext* ctx,
                                               torch::autograd::tensor_list grad_outputs) {
    const auto s = ctx->get_saved_variables();
    const int64_t width = ctx->saved_data["width"].toInt(), height = ctx->saved_data["height"].toInt();
    const auto grad_image = grad_outputs[0].defined()
                                ? grad_outputs[0]
                                : torch::zeros({height, width, s[2].size(1)}, s[0].options());
    const c10::optional<torch::Tensor> grad_alpha =
        grad_outputs[1].defined() ? c10::optional<torch::Tensor>(grad_outputs[1]) : c10::nullopt;
    static const auto op = fskin_operator<RasterizeBackwardSignature>("fskin::_rasterize_gaussians_backward");
    const auto [g_means, g_conics, g_colors, g_opacities, g_background] =
        op.call(grad_image, grad_alpha, s[7], s[8], s[9], s[10], s[0], s[1], s[2], s[3], s[4], s[5], s[6], width, height,
                {ctx->needs_input_grad(0), ctx->needs_input_grad(1), ctx->needs_input_grad(2),
                 ctx->needs_input_grad(3), ctx->needs_input_grad(6)});
    return {g_means, g_conics, g_colors, g_opacities, torch::Tensor(), torch::Tensor(), g_background,
            torch::Tensor(), torch::Tensor()};
  }
};

std::tuple<torch::Tensor, torch::Tensor> rasterize_gaussians_autograd(
    const torch::Tensor& means2d, const torch::Tensor& conics, const torch::Tensor& colors,
    const torch::Tensor& opacities, const torch::Tensor& depths, const torch::Tensor& radii,
    const torch::Tensor& background, int64_t width, int64_t height) {
  const auto out =
      RasterizeFunction::apply(means2d, conics, colors, opacities, depths, radii, background, width, height);
  return {out[0], out[1]};
}

// The backward op under Autograd: it has no derivative of its own, so
// differentiating it (create_graph) is an error, not gradients that silently stop.
std::tuple<torch::Tensor, torch::Tensor, torch::Tensor, torch::Tensor, torch::Tensor>
rasterize_gaussians_backward_autograd(const torch::Tensor& grad_image, const c10::optional<torch::Tensor>& grad_alpha,
                                      const torch::Tensor& image, const torch::Tensor& alpha,
                                      const torch::Tensor& tile_gaussians, const torch::Tensor& tile_ranges,
                                      const torch::Tensor& means2d, const torch::Tensor& conics,
                                      const torch::Tensor& colors, const torch::Tensor& opacities,
                                      const torch::Tensor& depths, const torch::Tensor& radii,
                                      const torch::Tensor& background, int64_t width, int64_t height,
                                      std::array<bool, 5> output_mask) {
  bool differentiated = grad_image.requires_grad() || (grad_alpha && grad_alpha->requires_grad());
  for (const auto* t : {&means2d, &conics, &colors, &opacities, &background}) {
    differentiated = differentiated || t->requires_grad();
  }
  FSKIN_CHECK(!(torch::GradMode::is_enabled() && differentiated),
              "rasterize_gaussians: double backward (create_graph=True) is not supported");
  at::AutoDispatchBelowADInplaceOrView below_autograd;
  static const auto op = fskin_operator<RasterizeBackwardSignature>("fskin::_rasterize_gaussians_backward");
  return op.call(grad_image, grad_alpha, image, alpha, tile_gaussians, tile_ranges, means2d, conics, colors, opacities, depths, radii, background,
                 width, height, output_mask);
}

}  // namespace

TORCH_LIBRARY_FRAGMENT(fskin, m) {
  m.def(
      "rasterize_gaussians(Tensor means2d, Tensor conics, Tensor colors, Tensor opacities, Tensor depths, "
      "Tensor radii, Tensor background, int width, int height) -> (Tensor image, Tensor alpha)");
  m.def(
      "_rasterize_gaussians_forward(Tensor means2d, Tensor conics, Tensor colors, Tensor opacities, Tensor depths, "
      "Tensor radii, Tensor background, int width, int height) -> (Tensor image, Tensor alpha, "
      "Tensor tile_gaussians, Tensor tile_ranges)");
  m.def(
      "_rasterize_gaussians_backward(Tensor grad_image, Tensor? grad_alpha, Tensor image, Tensor alpha, "
      "Tensor tile_gaussians, Tensor tile_ranges, Tensor means2d, Tensor conics, "
      "Tensor colors, Tensor opacities, Tensor depths, Tensor radii, Tensor background, int width, int height, "
      "bool[5] output_mask) -> (Tensor, Tensor, Tensor, Tensor, Tensor)");
}

TORCH_LIBRARY_IMPL(fskin, CPU, m) {
  m.impl("rasterize_gaussians", TORCH_FN(rasterize_gaussians_kernel));
  m.impl("_rasterize_gaussians_forward", TORCH_FN(rasterize_gaussians_forward_kernel));
  m.impl("_rasterize_gaussians_backward", TORCH_FN(rasterize_gaussians_backward_kernel));
}

#ifdef FSKIN_WITH_CUDA
TORCH_LIBRARY_IMPL(fskin, CUDA, m) {
  m.impl("rasterize_gaussians", TORCH_FN(rasterize_gaussians_kernel));
  m.impl("_rasterize_gaussians_forward", TORCH_FN(rasterize_gaussians_forward_kernel));
  m.impl("_rasterize_gaussians_backward", TORCH_FN(rasterize_gaussians_backward_kernel));
}
#endif

TORCH_LIBRARY_IMPL(fskin, Autograd, m) {
  m.impl("rasterize_gaussians", TORCH_FN(rasterize_gaussians_autograd));
  m.impl("_rasterize_gaussians_backward", TORCH_FN(rasterize_gaussians_backward_autograd));
}

std::tuple<torch::Tensor, torch::Tensor> rasterize_gaussians(const torch::Tensor& means2d, const torch::Tensor& conics,
                                                             const torch::Tensor& colors,
                                                             const torch::Tensor& opacities,
                                                             const torch::Tensor& depths, const torch::Tensor& radii,
                                                             const torch::Tensor& background, int64_t width,
                                                             int64_t height) {
  static const auto op = fskin_operator<RasterizeSignature>("fskin::rasterize_gaussians");
  return op.call(means2d, conics, colors, opacities, depths, radii, background, width, height);
}

std::tuple<torch::Tensor, torch::Tensor> rasterize_gaussians_reference(
    const torch::Tensor& means2d, const torch::Tensor& conics, const torch::Tensor& colors,
    const torch::Tensor& opacities, const torch::Tensor& depths, const torch::Tensor& radii,
    const torch::Tensor& background, int64_t width, int64_t height) {
  check_inputs(means2d, conics, colors, opacities, depths, radii, background, width, height);
  const auto options = means2d.options();
  const auto index_options = options.dtype(torch::kInt64);
  // Every pixel against every Gaussian, in depth order.
  const auto order = std::get<1>(torch::sort(depths, /*stable=*/true, 0, false));
  const auto mean = means2d.index_select(0, order), q = conics.index_select(0, order);
  const auto xs = torch::arange(width, index_options), ys = torch::arange(height, index_options);
  const auto grid = torch::meshgrid({ys, xs}, "ij");
  const auto pixel_x = grid[1].reshape({-1, 1}), pixel_y = grid[0].reshape({-1, 1});  // [P, 1] int64
  const auto dx = pixel_x.to(options) - mean.select(1, 0).unsqueeze(0);
  const auto dy = pixel_y.to(options) - mean.select(1, 1).unsqueeze(0);
  const auto power = -0.5 * (q.select(1, 0) * dx * dx + q.select(1, 2) * dy * dy) - q.select(1, 1) * dx * dy;
  const auto alpha = torch::clamp_max(opacities.index_select(0, order) * torch::exp(power), 0.99);
  // The op's tiles: a Gaussian reaches only the pixels of the tiles its rectangle covers.
  const auto [x0, x1, y0, y1] = tile_rectangles(means2d.detach(), radii, tiles_for(width, height));
  const auto tile_x = pixel_x.div(gr::kTileSize, "trunc"), tile_y = pixel_y.div(gr::kTileSize, "trunc");
  const auto in_rectangle = (tile_x >= x0.index_select(0, order)) & (tile_x < x1.index_select(0, order)) &
                            (tile_y >= y0.index_select(0, order)) & (tile_y < y1.index_select(0, order));
  const auto counts = (power <= 0) & (alpha >= 1.0 / 255.0) & in_rectangle;
  auto blended = torch::where(counts, alpha, torch::zeros_like(alpha));
  // Early stop: the first Gaussian that would take T under 1e-4 and all behind it are left out.
  const auto kept_transmittance = torch::cumprod(1 - blended.detach(), 1);
  const auto stopped = torch::cumsum((kept_transmittance < 1e-4).to(torch::kInt64), 1) > 0;
  blended = torch::where(stopped, torch::zeros_like(blended), blended);
  const auto ones = torch::ones({blended.size(0), 1}, options);
  const auto transmittance = torch::cumprod(torch::cat({ones, 1 - blended}, 1), 1);
  const auto weights = transmittance.narrow(1, 0, blended.size(1)) * blended;
  const auto final_transmittance = transmittance.select(1, blended.size(1)).unsqueeze(1);
  const auto image = torch::matmul(weights, colors.index_select(0, order)) + final_transmittance * background;
  return {image.view({height, width, colors.size(1)}), (1 - final_transmittance).view({height, width})};
}

}  // namespace fskin

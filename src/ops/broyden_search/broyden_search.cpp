// broyden_search as the dispatcher op fskin::broyden_search (schema, CPU /
// CUDA kernels; ops/common/dispatcher.h): validates the inputs, fills the raw
// launch arguments and dispatches on dtype.
#include "fskin/ops/broyden_search.h"

#include <torch/library.h>
#include <torch/torch.h>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "ops/broyden_search/broyden_search_kernel.h"
#include "ops/common/box_arguments.h"
#include "ops/common/dispatcher.h"
#include "ops/common/run_on_device.h"
#include "ops/common/transform_grid_view.h"

namespace fskin {

namespace {

template <typename T>
broyden::SearchLaunch<T> make_launch(const torch::Tensor& grid, const VoxelBox& box, const torch::Tensor& x_posed,
                                     const torch::Tensor& starts, const torch::Tensor& start_weights,
                                     int64_t slots, const BroydenSearchOptions& o, BroydenSearchResult& r) {
  broyden::SearchLaunch<T> a{};
  a.grid = transform_grid_view<T>(grid, box);
  a.grid_frame_stride = grid[0].numel();
  a.x_posed = x_posed.data_ptr<T>();
  a.start_inverses = starts.data_ptr<T>();
  a.start_weights = start_weights.defined() ? start_weights.data_ptr<T>() : nullptr;
  a.batch = x_posed.size(0);
  a.points = x_posed.size(1);
  a.starts = static_cast<int>(starts.size(1));
  a.slots = static_cast<int>(slots);
  a.params = {o.max_iterations, static_cast<T>(o.converge_sq), static_cast<T>(o.diverge_sq),
              static_cast<T>(o.denominator_eps), o.final_step};
  a.x_out = r.x_canonical.data_ptr<T>();
  a.valid_out = r.valid.data_ptr<bool>();
  a.iterations_out = r.iterations.data_ptr<uint8_t>();
  a.start_index_out = r.start_index.data_ptr<int64_t>();
  a.inverse_jacobian_out = r.inverse_jacobian.defined() ? r.inverse_jacobian.data_ptr<T>() : nullptr;
  return a;
}

using SearchOutputs = std::tuple<torch::Tensor, torch::Tensor, torch::Tensor, torch::Tensor, torch::Tensor>;
using SearchSignature = SearchOutputs(const torch::Tensor&, c10::ArrayRef<double>, c10::ArrayRef<double>,
                                      const torch::Tensor&, const torch::Tensor&, const c10::optional<torch::Tensor>&,
                                      int64_t, double, double, double, bool, int64_t, bool);

// The CPU and CUDA keys' kernel (one function: the devices share the per-pair
// core and launch arguments; run_on_device picks the launch). Not
// differentiable by itself: the deformers attach the implicit gradient.
SearchOutputs broyden_search_kernel(const torch::Tensor& transform_grid, c10::ArrayRef<double> box_offset,
                                    c10::ArrayRef<double> box_scale, const torch::Tensor& x_posed,
                                    const torch::Tensor& start_inverses,
                                    const c10::optional<torch::Tensor>& optional_start_weights,
                                    int64_t max_iterations, double converge_sq, double diverge_sq,
                                    double denominator_eps, bool final_step, int64_t num_starts,
                                    bool return_inverse_jacobian) {
  const auto box = box_from_arguments(box_offset, box_scale, transform_grid, "broyden_search");
  FSKIN_CHECK(max_iterations >= 0 && max_iterations <= 255, "broyden_search: max_iterations = {} must be in 0..255",
              max_iterations);
  BroydenSearchOptions options;
  options.max_iterations = static_cast<int>(max_iterations);
  options.converge_sq = converge_sq;
  options.diverge_sq = diverge_sq;
  options.denominator_eps = denominator_eps;
  options.final_step = final_step;
  options.num_starts = num_starts;
  options.return_inverse_jacobian = return_inverse_jacobian;
  const torch::Tensor start_weights = optional_start_weights ? *optional_start_weights : torch::Tensor();
  expect_shape(x_posed, {-1, -1, 3}, "broyden_search: x_posed");
  const int64_t B = x_posed.size(0), N = x_posed.size(1);
  expect_shape(transform_grid, {B, box.shape.depth, box.shape.height, box.shape.width, kernels::kChannels},
               "broyden_search: transform_grid");
  expect_shape(start_inverses, {B, -1, 4, 4}, "broyden_search: start_inverses");
  const int64_t S = start_inverses.size(1);
  FSKIN_CHECK(S >= 1 && S <= broyden::kMaxStarts, "broyden_search: {} start bones, expected 1..{}", S,
              broyden::kMaxStarts);
  const int64_t I = options.num_starts < 0 ? S : options.num_starts;
  FSKIN_CHECK(I >= 1 && I <= S, "broyden_search: num_starts = {} must be in 1..{} (the start bones given)",
              options.num_starts, S);
  FSKIN_CHECK(options.converge_sq > 0 && options.diverge_sq > options.converge_sq,
              "broyden_search: thresholds must satisfy 0 < converge_sq ({}) < diverge_sq ({})",
              options.converge_sq, options.diverge_sq);
  const auto dtype = x_posed.scalar_type();
  FSKIN_CHECK(dtype == torch::kFloat32 || dtype == torch::kFloat64,
              "broyden_search: x_posed must be float32 or float64");
  FSKIN_CHECK(transform_grid.scalar_type() == dtype && start_inverses.scalar_type() == dtype,
              "broyden_search: transform_grid, x_posed and start_inverses must share one dtype");
  FSKIN_CHECK(transform_grid.device() == x_posed.device() && start_inverses.device() == x_posed.device(),
              "broyden_search: all inputs must be on one device");
  expect_finite_on_cpu(start_inverses, "broyden_search: start_inverses");
  torch::Tensor weights;
  if (I < S) {
    expect_shape(start_weights, {box.shape.depth, box.shape.height, box.shape.width, S},
                 "broyden_search: start_weights (needed by the automatic start selection)");
    FSKIN_CHECK(start_weights.device() == x_posed.device(), "broyden_search: start_weights on another device");
    weights = start_weights.detach().to(dtype).contiguous();
  }

  const auto grid = transform_grid.detach().contiguous();
  const auto xp = x_posed.detach().contiguous();
  // The kernel reads the top 3x4 block of each start transform.
  const auto starts = start_inverses.detach().narrow(2, 0, 3).contiguous();
  const auto opts = xp.options();
  BroydenSearchResult r;
  r.x_canonical = torch::empty({B, N, I, 3}, opts);
  r.valid = torch::empty({B, N, I}, opts.dtype(torch::kBool));
  r.iterations = torch::empty({B, N, I}, opts.dtype(torch::kUInt8));
  r.start_index = torch::empty({B, N, I}, opts.dtype(torch::kInt64));
  if (options.return_inverse_jacobian) r.inverse_jacobian = torch::empty({B, N, I, 3, 3}, opts);
  const SearchOutputs outputs{r.x_canonical, r.valid, r.iterations, r.start_index, r.inverse_jacobian};
  if (B * N == 0) return outputs;

  AT_DISPATCH_FLOATING_TYPES(dtype, "broyden_search", [&] {
    const auto launch = make_launch<scalar_t>(grid, box, xp, starts, weights, I, options, r);
    run_on_device(
        xp, "broyden_search", [&] { broyden::broyden_search_cpu(launch); },
        [&](void* stream) { broyden::broyden_search_cuda(launch, stream); });
  });
  return outputs;
}

}  // namespace

TORCH_LIBRARY_FRAGMENT(fskin, m) {
  m.def(
      "broyden_search(Tensor transform_grid, float[] box_offset, float[] box_scale, Tensor x_posed, "
      "Tensor start_inverses, Tensor? start_weights=None, int max_iterations=10, float converge_sq=1e-08, "
      "float diverge_sq=0.25, float denominator_eps=0., bool final_step=True, int num_starts=-1, "
      "bool return_inverse_jacobian=False) -> (Tensor x_canonical, Tensor valid, Tensor iterations, "
      "Tensor start_index, Tensor inverse_jacobian)");
}

TORCH_LIBRARY_IMPL(fskin, CPU, m) { m.impl("broyden_search", TORCH_FN(broyden_search_kernel)); }

#ifdef FSKIN_WITH_CUDA
TORCH_LIBRARY_IMPL(fskin, CUDA, m) { m.impl("broyden_search", TORCH_FN(broyden_search_kernel)); }
#endif

BroydenSearchResult broyden_search(const torch::Tensor& transform_grid, const VoxelBox& box,
                                   const torch::Tensor& x_posed, const torch::Tensor& start_inverses,
                                   const BroydenSearchOptions& options, const torch::Tensor& start_weights) {
  expect_grid_over_box(transform_grid, box, "broyden_search");
  static const auto op = fskin_operator<SearchSignature>("fskin::broyden_search");
  const auto [x, valid, iterations, start_index, inverse_jacobian] =
      op.call(transform_grid, box_offset_argument(box), box_scale_argument(box), x_posed, start_inverses,
              start_weights.defined() ? c10::optional<torch::Tensor>(start_weights) : c10::nullopt,
              options.max_iterations, options.converge_sq, options.diverge_sq, options.denominator_eps,
              options.final_step, options.num_starts, options.return_inverse_jacobian);
  return {x, valid, iterations, start_index, inverse_jacobian};
}

}  // namespace fskin

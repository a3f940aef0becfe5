// hash_encoding as the dispatcher op fskin::hash_encoding (schema, CPU / CUDA
// kernels, Autograd; ops/common/dispatcher.h): validates the inputs, fills the
// raw launch arguments, dispatches on dtype, and wires forward and backward
// into autograd. Also the LibTorch reference of the same encoding.
#include "fskin/ops/hash_encoding.h"

#include <torch/library.h>
#include <torch/torch.h>

#include <array>
#include <cmath>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "ops/common/dispatcher.h"
#include "ops/common/run_on_device.h"
#include "ops/hash_encoding/hash_encoding_kernel.h"

namespace fskin {

static_assert(kMaxHashLevels == hash_grid::kMaxLevels, "one level limit for the op and its kernels");

int64_t HashEncodingOptions::resolution(int64_t level) const {
  return static_cast<int64_t>(std::floor(static_cast<double>(base_resolution) * std::pow(per_level_scale, level)));
}

bool HashEncodingOptions::hashed(int64_t level) const {
  const double side = static_cast<double>(resolution(level) + 1);
  return side * side * side > static_cast<double>(table_size());
}

HashEncodingOptions HashEncodingOptions::spanning(int64_t levels, int64_t base_resolution, int64_t finest_resolution,
                                                  int64_t log2_table_size, int64_t features_per_level) {
  FSKIN_CHECK(levels >= 1 && base_resolution >= 1 && finest_resolution >= base_resolution,
              "hash encoding: {} levels from resolution {} to {}: need levels >= 1 and 1 <= base <= finest", levels,
              base_resolution, finest_resolution);
  HashEncodingOptions o;
  o.levels = levels;
  o.features_per_level = features_per_level;
  o.log2_table_size = log2_table_size;
  o.base_resolution = base_resolution;
  o.per_level_scale = levels > 1 ? std::exp(std::log(static_cast<double>(finest_resolution) /
                                                     static_cast<double>(base_resolution)) /
                                            static_cast<double>(levels - 1))
                                 : 1.0;
  return o;
}

void HashEncodingOptions::validate() const {
  FSKIN_CHECK(levels >= 1 && levels <= kMaxHashLevels, "hash encoding: levels {} must be in 1..{}", levels,
              kMaxHashLevels);
  FSKIN_CHECK(features_per_level >= 1 && features_per_level <= 8,
              "hash encoding: features_per_level {} must be in 1..8", features_per_level);
  FSKIN_CHECK(log2_table_size >= 4 && log2_table_size <= 24, "hash encoding: log2_table_size {} must be in 4..24",
              log2_table_size);
  constexpr int64_t kMaxResolution = int64_t{1} << 20;
  FSKIN_CHECK(base_resolution >= 1 && base_resolution <= kMaxResolution,
              "hash encoding: base_resolution {} must be in 1..2^20", base_resolution);
  FSKIN_CHECK(std::isfinite(per_level_scale) && per_level_scale >= 1,
              "hash encoding: per_level_scale {} must be >= 1", per_level_scale);
  // In floating point first: the integer resolution of a huge scale would overflow.
  const double finest = static_cast<double>(base_resolution) * std::pow(per_level_scale, levels - 1);
  FSKIN_CHECK(finest <= static_cast<double>(kMaxResolution), "hash encoding: finest resolution {:g} is above 2^20",
              finest);
}

namespace {

void check_inputs(const torch::Tensor& positions, const torch::Tensor& table, const HashEncodingOptions& o) {
  o.validate();
  expect_shape(positions, {-1, 3}, "hash_encoding: positions");
  expect_shape(table, {o.levels, o.table_size(), o.features_per_level}, "hash_encoding: table");
  const auto dtype = positions.scalar_type();
  FSKIN_CHECK(dtype == torch::kFloat32 || dtype == torch::kFloat64,
              "hash_encoding: positions must be float32 or float64, got {}", c10::toString(dtype));
  FSKIN_CHECK(table.scalar_type() == dtype, "hash_encoding: table ({}) and positions ({}) must share one dtype",
              c10::toString(table.scalar_type()), c10::toString(dtype));
  FSKIN_CHECK(table.device() == positions.device(), "hash_encoding: table and positions on different devices");
}

template <typename T>
hash_grid::EncodingLaunch<T> launch_for(const torch::Tensor& positions, const torch::Tensor& table,
                                            const HashEncodingOptions& o) {
  hash_grid::EncodingLaunch<T> a{};
  a.positions = positions.data_ptr<T>();
  a.table = table.data_ptr<T>();
  a.points = positions.size(0);
  a.levels = o.levels;
  a.features = o.features_per_level;
  a.table_size = o.table_size();
  for (int64_t l = 0; l < o.levels; ++l) {
    a.resolution[l] = o.resolution(l);
    a.hashed[l] = o.hashed(l);
  }
  return a;
}

torch::Tensor encode(const torch::Tensor& positions, const torch::Tensor& table, const HashEncodingOptions& o) {
  auto out = torch::empty({positions.size(0), o.output_dim()}, positions.options());
  if (positions.size(0) == 0) return out;
  AT_DISPATCH_FLOATING_TYPES(positions.scalar_type(), "hash_encoding", [&] {
    auto a = launch_for<scalar_t>(positions, table, o);
    a.out = out.data_ptr<scalar_t>();
    run_on_device(
        positions, "hash_encoding", [&] { hash_grid::hash_encoding_forward_cpu(a); },
        [&](void* stream) { hash_grid::hash_encoding_forward_cuda(a, stream); });
  });
  return out;
}

// The dispatcher's schema carries the table and (N_min, b); L, F and T are the table's shape.
HashEncodingOptions options_of(const torch::Tensor& table, int64_t base_resolution, double per_level_scale) {
  FSKIN_CHECK(table.dim() == 3, "hash_encoding: table must be [levels, 2^T, features], got {} dimensions", table.dim());
  HashEncodingOptions o;
  o.levels = table.size(0);
  o.features_per_level = table.size(2);
  const int64_t rows = table.size(1);
  FSKIN_CHECK(rows >= 1 && (rows & (rows - 1)) == 0, "hash_encoding: table rows {} must be a power of two (2^T)", rows);
  o.log2_table_size = 0;
  while ((int64_t{1} << o.log2_table_size) < rows) ++o.log2_table_size;
  o.base_resolution = base_resolution;
  o.per_level_scale = per_level_scale;
  return o;
}

using EncodingSignature = torch::Tensor(const torch::Tensor&, const torch::Tensor&, int64_t, double);
using EncodingBackwardSignature = std::tuple<torch::Tensor, torch::Tensor>(
    const torch::Tensor&, const torch::Tensor&, const torch::Tensor&, int64_t, double, std::array<bool, 2>);

// The CPU and CUDA keys' kernel (one function: the devices share the per-point
// core and launch arguments; run_on_device picks the launch).
torch::Tensor hash_encoding_kernel(const torch::Tensor& positions, const torch::Tensor& table, int64_t base_resolution,
                                   double per_level_scale) {
  const auto o = options_of(table, base_resolution, per_level_scale);
  check_inputs(positions, table, o);
  return encode(positions.contiguous(), table.contiguous(), o);
}

// d features -> (d positions, d table); output_mask says which are wanted.
std::tuple<torch::Tensor, torch::Tensor> hash_encoding_backward_kernel(const torch::Tensor& grad_features,
                                                                       const torch::Tensor& positions_in,
                                                                       const torch::Tensor& table_in,
                                                                       int64_t base_resolution, double per_level_scale,
                                                                       std::array<bool, 2> output_mask) {
  const auto o = options_of(table_in, base_resolution, per_level_scale);
  check_inputs(positions_in, table_in, o);
  const auto positions = positions_in.contiguous(), table = table_in.contiguous();
  expect_shape(grad_features, {positions.size(0), o.output_dim()}, "hash_encoding backward: grad_features");
  const auto grad_out = grad_features.to(positions.options()).contiguous();
  torch::Tensor grad_positions, grad_table;
  if (output_mask[0]) grad_positions = torch::empty_like(positions);
  if (output_mask[1]) grad_table = torch::zeros_like(table);
  if (positions.size(0) > 0 && (grad_positions.defined() || grad_table.defined())) {
    AT_DISPATCH_FLOATING_TYPES(positions.scalar_type(), "hash_encoding backward", [&] {
      auto a = launch_for<scalar_t>(positions, table, o);
      a.grad_out = grad_out.data_ptr<scalar_t>();
      a.grad_positions = grad_positions.defined() ? grad_positions.data_ptr<scalar_t>() : nullptr;
      a.grad_table = grad_table.defined() ? grad_table.data_ptr<scalar_t>() : nullptr;
      run_on_device(
          positions, "hash_encoding backward", [&] { hash_grid::hash_encoding_backward_cpu(a); },
          [&](void* stream) { hash_grid::hash_encoding_backward_cuda(a, stream); });
    });
  } else if (grad_positions.defined()) {
    grad_positions.zero_();
  }
  return {grad_positions, grad_table};
}

// The Autograd key: records the graph and runs the kernels below it.
class HashEncodingFunction : public torch::autograd::Function<HashEncodingFunction> {
 public:
  static torch::Tensor forward(torch::autograd::AutogradContext* ctx, const torch::Tensor& positions,
                               const torch::Tensor& table, int64_t base_resolution, double per_level_scale) {
    ctx->save_for_backward({positions, table});
    ctx->saved_data["base_resolution"] = base_resolution;
    ctx->saved_data["per_level_scale"] = per_level_scale;
    at::AutoDispatchBelowADInplaceOrView below_autograd;
    static const auto op = fskin_operator<EncodingSignature>("fskin::hash_encoding");
    return op.call(positions, table, base_resolution, per_level_scale);
  }

  static torch::autograd::tensor_list backward(torch::autograd::AutogradContext* ctx,
                                               torch::autograd::tensor_list grad_outputs) {
    const auto saved = ctx->get_saved_variables();
    static const auto op = fskin_operator<EncodingBackwardSignature>("fskin::_hash_encoding_backward");
    const auto [grad_positions, grad_table] =
        op.call(grad_outputs[0], saved[0], saved[1], ctx->saved_data["base_resolution"].toInt(),
                ctx->saved_data["per_level_scale"].toDouble(), {ctx->needs_input_grad(0), ctx->needs_input_grad(1)});
    return {grad_positions, grad_table, torch::Tensor(), torch::Tensor()};
  }
};

torch::Tensor hash_encoding_autograd(const torch::Tensor& positions, const torch::Tensor& table,
                                     int64_t base_resolution, double per_level_scale) {
  return HashEncodingFunction::apply(positions, table, base_resolution, per_level_scale);
}

// The backward op under Autograd: no derivative of its own (no double backward).
std::tuple<torch::Tensor, torch::Tensor> hash_encoding_backward_autograd(const torch::Tensor& grad_features,
                                                                         const torch::Tensor& positions,
                                                                         const torch::Tensor& table,
                                                                         int64_t base_resolution,
                                                                         double per_level_scale,
                                                                         std::array<bool, 2> output_mask) {
  const bool differentiated = grad_features.requires_grad() || positions.requires_grad() || table.requires_grad();
  FSKIN_CHECK(!(torch::GradMode::is_enabled() && differentiated),
              "hash_encoding: double backward (create_graph=True) is not supported");
  at::AutoDispatchBelowADInplaceOrView below_autograd;
  static const auto op = fskin_operator<EncodingBackwardSignature>("fskin::_hash_encoding_backward");
  return op.call(grad_features, positions, table, base_resolution, per_level_scale, output_mask);
}

}  // namespace

TORCH_LIBRARY_FRAGMENT(fskin, m) {
  m.def("hash_encoding(Tensor positions, Tensor table, int base_resolution, float per_level_scale) -> Tensor");
  m.def(
      "_hash_encoding_backward(Tensor grad_features, Tensor positions, Tensor table, int base_resolution, "
      "float per_level_scale, bool[2] output_mask) -> (Tensor, Tensor)");
}

TORCH_LIBRARY_IMPL(fskin, CPU, m) {
  m.impl("hash_encoding", TORCH_FN(hash_encoding_kernel));
  m.impl("_hash_encoding_backward", TORCH_FN(hash_encoding_backward_kernel));
}

#ifdef FSKIN_WITH_CUDA
TORCH_LIBRARY_IMPL(fskin, CUDA, m) {
  m.impl("hash_encoding", TORCH_FN(hash_encoding_kernel));
  m.impl("_hash_encoding_backward", TORCH_FN(hash_encoding_backward_kernel));
}
#endif

TORCH_LIBRARY_IMPL(fskin, Autograd, m) {
  m.impl("hash_encoding", TORCH_FN(hash_encoding_autograd));
  m.impl("_hash_encoding_backward", TORCH_FN(hash_encoding_backward_autograd));
}

torch::Tensor hash_encoding(const torch::Tensor& positions, const torch::Tensor& table,
                            const HashEncodingOptions& options) {
  check_inputs(positions, table, options);
  expect_finite_on_cpu(positions, "hash_encoding: positions");
  static const auto op = fskin_operator<EncodingSignature>("fskin::hash_encoding");
  return op.call(positions, table, options.base_resolution, options.per_level_scale);
}

torch::Tensor hash_encoding_table(const HashEncodingOptions& options, torch::TensorOptions tensor_options) {
  options.validate();
  return (torch::rand({options.levels, options.table_size(), options.features_per_level}, tensor_options) * 2 - 1) *
         1e-4;
}

torch::Tensor hash_encoding_reference(const torch::Tensor& positions, const torch::Tensor& table,
                                      const HashEncodingOptions& o) {
  check_inputs(positions, table, o);
  const auto clamped = positions.clamp(0.0, 1.0);
  std::vector<torch::Tensor> levels;
  for (int64_t l = 0; l < o.levels; ++l) {
    const int64_t r = o.resolution(l);
    const auto scaled = clamped * static_cast<double>(r);
    const auto base = scaled.detach().floor().clamp_max(static_cast<double>(r - 1));
    const auto frac = scaled - base;  // carries the position gradient
    const auto base_index = base.to(torch::kInt64);
    auto features = torch::zeros({positions.size(0), o.features_per_level}, positions.options());
    for (int corner = 0; corner < 8; ++corner) {
      torch::Tensor w = torch::ones({positions.size(0)}, positions.options());
      std::vector<torch::Tensor> vertex;
      for (int a = 0; a < 3; ++a) {
        const bool upper = (corner >> a) & 1;
        w = w * (upper ? frac.select(1, a) : 1 - frac.select(1, a));
        vertex.push_back(base_index.select(1, a) + (upper ? 1 : 0));
      }
      torch::Tensor row;
      if (!o.hashed(l)) {
        row = vertex[0] + (r + 1) * (vertex[1] + (r + 1) * vertex[2]);
      } else {
        // uint32 arithmetic of the kernel, in int64: products mod 2^32, then the low T bits.
        const int64_t mask32 = 0xFFFFFFFF;
        const auto hy = (vertex[1] * static_cast<int64_t>(2654435761)).bitwise_and(mask32);
        const auto hz = (vertex[2] * static_cast<int64_t>(805459861)).bitwise_and(mask32);
        row = vertex[0].bitwise_xor(hy).bitwise_xor(hz).bitwise_and(o.table_size() - 1);
      }
      features = features + w.unsqueeze(1) * table[l].index_select(0, row);
    }
    levels.push_back(features);
  }
  return torch::cat(levels, 1);
}

}  // namespace fskin

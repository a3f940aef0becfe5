// hash_encoding: validates the inputs, fills the raw launch arguments,
// dispatches on device and dtype, and wires forward and backward into
// autograd. Also the LibTorch reference of the same encoding.
#include "fskin/ops/hash_encoding.h"

#include <torch/torch.h>

#include <cmath>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
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

HashEncodingOptions options_from(torch::autograd::AutogradContext* ctx) {
  HashEncodingOptions o;
  o.levels = ctx->saved_data["levels"].toInt();
  o.features_per_level = ctx->saved_data["features"].toInt();
  o.log2_table_size = ctx->saved_data["log2_table_size"].toInt();
  o.base_resolution = ctx->saved_data["base_resolution"].toInt();
  o.per_level_scale = ctx->saved_data["per_level_scale"].toDouble();
  return o;
}

class HashEncodingFunction : public torch::autograd::Function<HashEncodingFunction> {
 public:
  static torch::Tensor forward(torch::autograd::AutogradContext* ctx, const torch::Tensor& positions,
                               const torch::Tensor& table, const HashEncodingOptions& o) {
    const auto p = positions.contiguous(), t = table.contiguous();
    ctx->save_for_backward({p, t});
    ctx->saved_data["levels"] = o.levels;
    ctx->saved_data["features"] = o.features_per_level;
    ctx->saved_data["log2_table_size"] = o.log2_table_size;
    ctx->saved_data["base_resolution"] = o.base_resolution;
    ctx->saved_data["per_level_scale"] = o.per_level_scale;
    return encode(p, t, o);
  }

  static torch::autograd::tensor_list backward(torch::autograd::AutogradContext* ctx,
                                               torch::autograd::tensor_list grad_outputs) {
    const auto saved = ctx->get_saved_variables();
    const auto& positions = saved[0];
    const auto& table = saved[1];
    const auto o = options_from(ctx);
    const auto grad_out = grad_outputs[0].contiguous();
    torch::Tensor grad_positions, grad_table;
    if (ctx->needs_input_grad(0)) grad_positions = torch::empty_like(positions);
    if (ctx->needs_input_grad(1)) grad_table = torch::zeros_like(table);
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
    return {grad_positions, grad_table, torch::Tensor()};
  }
};

}  // namespace

torch::Tensor hash_encoding(const torch::Tensor& positions, const torch::Tensor& table,
                            const HashEncodingOptions& options) {
  check_inputs(positions, table, options);
  expect_finite_on_cpu(positions, "hash_encoding: positions");
  return HashEncodingFunction::apply(positions, table, options);
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

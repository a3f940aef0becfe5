#include "fskin/ops/pin_pass.h"

#include <torch/library.h>

#include <array>
#include <vector>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "ops/common/dispatcher.h"
#include "ops/common/run_on_device.h"
#include "ops/pin_pass/pin_pass_kernel.h"

namespace fskin {

namespace {

using pin_pass::kMaxLayers;
using pin_pass::kMaxWidth;

// Sine layers of the space embedding: all of them, or all but a linear output
// layer, which the maps fold in instead.
int64_t sine_layer_count(const CouplingLayerOptions& o) {
  return o.space_linear_output ? o.space_layers - 1 : o.space_layers;
}

// The PIN's architecture as the op's int[] argument: layers, sine layers,
// SIREN hidden width, features, map hidden width, map layers, then per
// coupling layer its moved count, two moved axes and two kept axes.
constexpr int64_t kShapeHeader = 6, kShapePerLayer = 5;

std::vector<int64_t> shape_argument(const PinImpl& pin) {
  const auto& c = pin.options().coupling;
  // A linear output layer is folded into the maps, which then read the last
  // hidden sine layer; otherwise they read the E-wide sine embedding itself.
  std::vector<int64_t> shape = {static_cast<int64_t>(pin.layers().size()), sine_layer_count(c), c.space_hidden_dim,
                                c.space_linear_output ? c.space_hidden_dim : c.embedding_dim, c.map_hidden_dim,
                                c.map_hidden_layers};
  for (const auto& layer : pin.layers()) {
    std::array<int64_t, kShapePerLayer> entry{static_cast<int64_t>(layer->moved().size()), 0, 0, 0, 0};
    for (size_t i = 0; i < layer->moved().size() && i < 2; ++i) entry[1 + i] = layer->moved()[i];
    for (size_t i = 0; i < layer->kept().size() && i < 2; ++i) entry[3 + i] = layer->kept()[i];
    shape.insert(shape.end(), entry.begin(), entry.end());
  }
  return shape;
}

// The kernel's PinShape from the op's int[] (validated: the op is callable
// from Python with any list).
pin_pass::PinShape describe(c10::IntArrayRef shape) {
  FSKIN_CHECK(shape.size() >= static_cast<size_t>(kShapeHeader), "pin_pass: shape has {} entries, needs at least {}",
              shape.size(), kShapeHeader);
  const int64_t layers = shape[0];
  FSKIN_CHECK(layers >= 1 && layers <= kMaxLayers && static_cast<int64_t>(shape.size()) == kShapeHeader + kShapePerLayer * layers,
              "pin_pass: shape describes {} layers in {} entries (1 to {} layers, {} + {} per layer)", layers,
              shape.size(), kMaxLayers, kShapeHeader, kShapePerLayer);
  for (int64_t i = 1; i < kShapeHeader; ++i)
    FSKIN_CHECK(shape[i] >= 1 && shape[i] <= kMaxWidth, "pin_pass: shape[{}] = {} must be in [1, {}]", i, shape[i],
                kMaxWidth);
  pin_pass::PinShape s{};
  s.layers = static_cast<int>(layers);
  s.sine_layers = static_cast<int>(shape[1]);
  s.siren_hidden = static_cast<int>(shape[2]);
  s.features = static_cast<int>(shape[3]);
  s.map_hidden = static_cast<int>(shape[4]);
  s.map_layers = static_cast<int>(shape[5]);
  int64_t offset = 0;
  for (int k = 0; k < s.layers; ++k) {
    const auto* entry = shape.data() + kShapeHeader + kShapePerLayer * k;
    FSKIN_CHECK(entry[0] == 1 || entry[0] == 2, "pin_pass: layer {} moves {} axes (1 or 2)", k, entry[0]);
    for (int i = 1; i < kShapePerLayer; ++i)
      FSKIN_CHECK(entry[i] >= 0 && entry[i] <= 2, "pin_pass: layer {} names axis {} (0, 1 or 2)", k, entry[i]);
    s.moved_count[k] = static_cast<int>(entry[0]);
    s.moved[k][0] = static_cast<int>(entry[1]);
    s.moved[k][1] = static_cast<int>(entry[2]);
    s.kept[k][0] = static_cast<int>(entry[3]);
    s.kept[k][1] = static_cast<int>(entry[4]);
    s.layer_offset[k] = offset;
    offset += pin_pass::packed_layer_size(s, s.moved_count[k]);
  }
  return s;
}

// The packed floats per frame a shape needs.
int64_t packed_size(const pin_pass::PinShape& s) {
  return s.layer_offset[s.layers - 1] + pin_pass::packed_layer_size(s, s.moved_count[s.layers - 1]);
}

// Flattens t (shared by all frames) or t [B, ...] (per frame) into [B, numel / B].
torch::Tensor per_frame(const torch::Tensor& t, int64_t frames, bool shared) {
  return shared ? t.reshape({1, -1}).expand({frames, -1}) : t.reshape({frames, -1});
}

// The packed parameters of every frame, [B, P], in pin_pass_core.h's layout.
torch::Tensor pack(PinImpl& pin, const torch::Tensor& pose) {
  const int64_t B = pose.size(0);
  const auto& c = pin.options().coupling;
  std::vector<torch::Tensor> parts;
  const int64_t sine_layers = sine_layer_count(c);
  for (const auto& layer : pin.layers()) {
    const auto& siren_layers = layer->space_embedding()->layers();
    for (int64_t l = 0; l < sine_layers; ++l) {
      const double omega = l == 0 ? c.first_omega : c.hidden_omega;
      parts.push_back(per_frame(siren_layers[l]->weight * omega, B, true));
      parts.push_back(per_frame(siren_layers[l]->bias * omega, B, true));
    }
    SpaceProjection projection;
    if (c.space_linear_output) projection = {siren_layers.back()->weight, siren_layers.back()->bias};
    // Pre-activations in units of 1 / beta (pin_pass_core.h's layout).
    const double beta = OperationMapImpl::kSoftplusBeta;
    for (auto& map : layer->maps()) {
      const auto first = map->fold(pose, projection);
      parts.push_back(per_frame(first.weight * beta, B, false));
      parts.push_back(per_frame(first.bias * beta, B, false));
      for (const auto& hidden : map->hidden_layers()) {
        parts.push_back(per_frame(hidden->weight, B, true));
        parts.push_back(per_frame(hidden->bias * beta, B, true));
      }
      parts.push_back(per_frame(map->last_layer()->weight / beta, B, true));
      parts.push_back(per_frame(map->at_zero_conditioning(), B, true));
    }
  }
  return torch::cat(parts, 1).to(torch::kFloat32).contiguous();
}

torch::Tensor pin_pass_kernel(const torch::Tensor& points, const torch::Tensor& packed, c10::IntArrayRef shape,
                              bool inverse) {
  expect_shape(points, {-1, -1, 3}, "pin_pass: points");
  FSKIN_CHECK(points.scalar_type() == torch::kFloat32 && packed.scalar_type() == torch::kFloat32,
              "pin_pass: points and packed parameters must be float32, got {} and {}",
              c10::toString(points.scalar_type()), c10::toString(packed.scalar_type()));
  FSKIN_CHECK(packed.device() == points.device(), "pin_pass: points and packed parameters on different devices");
  const auto s = describe(shape);
  expect_shape(packed, {points.size(0), packed_size(s)}, "pin_pass: packed parameters");
  expect_finite_on_cpu(points, "pin_pass: points");
  const auto params = packed.contiguous();
  auto out = points.clone().contiguous();
  if (out.numel() == 0) return out;
  const pin_pass::PinPassLaunch launch{s, params.data_ptr<float>(), params.size(1), out.data_ptr<float>(),
                                       points.size(0), points.size(1), inverse};
  run_on_device(
      out, "pin_pass", [&] { pin_pass::pin_pass_cpu(launch); },
      [&](void* stream) { pin_pass::pin_pass_cuda(launch, stream); });
  return out;
}

}  // namespace

// Inference only: no Autograd kernel (training differentiates PinImpl's
// LibTorch forward_embedded / inverse_embedded).
TORCH_LIBRARY_FRAGMENT(fskin, m) {
  m.def("pin_pass(Tensor points, Tensor packed, int[] shape, bool inverse) -> Tensor");
}

TORCH_LIBRARY_IMPL(fskin, CPU, m) { m.impl("pin_pass", TORCH_FN(pin_pass_kernel)); }

#ifdef FSKIN_WITH_CUDA
TORCH_LIBRARY_IMPL(fskin, CUDA, m) { m.impl("pin_pass", TORCH_FN(pin_pass_kernel)); }
#endif

bool fused_pin_pass_supports(const PinImpl& pin) {
  const auto& c = pin.options().coupling;
  const int64_t features = c.space_linear_output ? c.space_hidden_dim : c.embedding_dim;
  return static_cast<int64_t>(pin.layers().size()) <= kMaxLayers && c.space_hidden_dim <= kMaxWidth &&
         features <= kMaxWidth && c.map_hidden_dim <= kMaxWidth;
}

FusedPinArguments fused_pin_arguments(PinImpl& pin, const torch::Tensor& pose_embedding) {
  expect_shape(pose_embedding, {-1, pin.options().coupling.embedding_dim}, "fused PIN pass: pose embedding");
  expect_finite_on_cpu(pose_embedding, "fused PIN pass: pose embedding");
  FSKIN_CHECK(fused_pin_pass_supports(pin),
              "fused PIN pass: the PIN is too large for the kernel ({} layers, widths {} / {} / {}; at most {} and {})",
              pin.layers().size(), pin.options().coupling.space_hidden_dim, pin.options().coupling.embedding_dim,
              pin.options().coupling.map_hidden_dim, kMaxLayers, kMaxWidth);
  torch::NoGradGuard no_grad;
  // The op checks the packed size against the shape (pin_pass_kernel), once.
  return {pack(pin, pose_embedding.to(torch::kFloat32)), shape_argument(pin)};
}

torch::Tensor fused_pin_pass(PinImpl& pin, const torch::Tensor& points, const torch::Tensor& pose_embedding,
                             bool inverse) {
  expect_shape(points, {-1, -1, 3}, "fused PIN pass: points");
  expect_shape(pose_embedding, {points.size(0), pin.options().coupling.embedding_dim}, "fused PIN pass: pose embedding");
  FSKIN_CHECK(points.scalar_type() == torch::kFloat32, "fused PIN pass: points must be float32, got {}",
              c10::toString(points.scalar_type()));
  FSKIN_CHECK(pose_embedding.device() == points.device(), "fused PIN pass: points and pose embedding on different devices");
  const auto arguments = fused_pin_arguments(pin, pose_embedding);
  static const auto op = fskin_operator<torch::Tensor(const torch::Tensor&, const torch::Tensor&, c10::IntArrayRef, bool)>(
      "fskin::pin_pass");
  torch::NoGradGuard no_grad;
  return op.call(points, arguments.packed, arguments.shape, inverse);
}

}  // namespace fskin

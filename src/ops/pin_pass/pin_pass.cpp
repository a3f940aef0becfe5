#include "fskin/ops/pin_pass.h"

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "ops/pin_pass/pin_pass_kernel.h"
#include "ops/common/run_on_device.h"

namespace fskin {

namespace {

using pin_pass::kMaxLayers;
using pin_pass::kMaxWidth;

// Sine layers of the space embedding: all of them, or all but a linear output
// layer, which the maps fold in instead.
int64_t sine_layer_count(const CouplingLayerOptions& o) {
  return o.space_linear_output ? o.space_layers - 1 : o.space_layers;
}

pin_pass::PinShape describe(const PinImpl& pin) {
  const auto& c = pin.options().coupling;
  pin_pass::PinShape s{};
  s.layers = static_cast<int>(pin.layers().size());
  s.sine_layers = static_cast<int>(sine_layer_count(c));
  s.siren_hidden = static_cast<int>(c.space_hidden_dim);
  // A linear output layer is folded into the maps, which then read the last
  // hidden sine layer; otherwise they read the E-wide sine embedding itself.
  s.features = static_cast<int>(c.space_linear_output ? c.space_hidden_dim : c.embedding_dim);
  s.map_hidden = static_cast<int>(c.map_hidden_dim);
  s.map_layers = static_cast<int>(c.map_hidden_layers);
  int64_t offset = 0;
  for (int k = 0; k < s.layers; ++k) {
    const auto& layer = *pin.layers()[k];
    s.moved_count[k] = static_cast<int>(layer.moved().size());
    for (size_t i = 0; i < layer.moved().size(); ++i) s.moved[k][i] = static_cast<int>(layer.moved()[i]);
    for (size_t i = 0; i < layer.kept().size(); ++i) s.kept[k][i] = static_cast<int>(layer.kept()[i]);
    s.layer_offset[k] = offset;
    offset += pin_pass::packed_layer_size(s, s.moved_count[k]);
  }
  return s;
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

}  // namespace

bool fused_pin_pass_supports(const PinImpl& pin) {
  const auto& c = pin.options().coupling;
  const int64_t features = c.space_linear_output ? c.space_hidden_dim : c.embedding_dim;
  return static_cast<int64_t>(pin.layers().size()) <= kMaxLayers && c.space_hidden_dim <= kMaxWidth &&
         features <= kMaxWidth && c.map_hidden_dim <= kMaxWidth;
}

torch::Tensor fused_pin_pass(PinImpl& pin, const torch::Tensor& points, const torch::Tensor& pose_embedding,
                             bool inverse) {
  expect_shape(points, {-1, -1, 3}, "fused PIN pass: points");
  expect_shape(pose_embedding, {points.size(0), pin.options().coupling.embedding_dim}, "fused PIN pass: pose embedding");
  FSKIN_CHECK(points.scalar_type() == torch::kFloat32, "fused PIN pass: points must be float32, got {}",
              c10::toString(points.scalar_type()));
  expect_finite_on_cpu(points, "fused PIN pass: points");
  expect_finite_on_cpu(pose_embedding, "fused PIN pass: pose embedding");
  FSKIN_CHECK(pose_embedding.device() == points.device(), "fused PIN pass: points and pose embedding on different devices");
  FSKIN_CHECK(fused_pin_pass_supports(pin),
              "fused PIN pass: the PIN is too large for the kernel ({} layers, widths {} / {} / {}; at most {} and {})",
              pin.layers().size(), pin.options().coupling.space_hidden_dim, pin.options().coupling.embedding_dim,
              pin.options().coupling.map_hidden_dim, kMaxLayers, kMaxWidth);
  torch::NoGradGuard no_grad;
  const auto params = pack(pin, pose_embedding.to(torch::kFloat32));
  auto out = points.clone().contiguous();
  pin_pass::PinPassLaunch launch{describe(pin), params.data_ptr<float>(), params.size(1), out.data_ptr<float>(),
                                 points.size(0), points.size(1), inverse};
  FSKIN_CHECK(launch.shape.layer_offset[launch.shape.layers - 1] +
                      pin_pass::packed_layer_size(launch.shape, launch.shape.moved_count[launch.shape.layers - 1]) ==
                  params.size(1),
              "fused PIN pass: packed {} floats per frame, the kernel expects a different layout", params.size(1));
  if (out.numel() == 0) return out;
  run_on_device(
      out, "fused PIN pass", [&] { pin_pass::pin_pass_cpu(launch); },
      [&](void* stream) { pin_pass::pin_pass_cuda(launch, stream); });
  return out;
}

}  // namespace fskin

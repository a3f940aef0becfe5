// composite_rays as the dispatcher op fskin::composite_rays (schema, CPU /
// CUDA kernels, Autograd; ops/common/dispatcher.h): validates the inputs,
// fills the raw launch arguments, dispatches on dtype, and wires forward and
// backward into autograd. Also the LibTorch reference of the same compositing.
#include "fskin/ops/ray_compositing.h"

#include <torch/library.h>
#include <torch/torch.h>

#include <array>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "ops/common/dispatcher.h"
#include "ops/ray_compositing/ray_compositing_op.h"
#include "ops/common/run_on_device.h"
#include "ops/ray_compositing/ray_compositing_kernel.h"

namespace fskin {
namespace {

void check_inputs(const torch::Tensor& sigma, const torch::Tensor& rgb, const torch::Tensor& delta,
                  const torch::Tensor& background) {
  expect_shape(sigma, {-1, -1}, "composite_rays: sigma");
  const int64_t R = sigma.size(0), S = sigma.size(1);
  expect_shape(rgb, {R, S, 3}, "composite_rays: rgb");
  expect_shape(delta, {R, S}, "composite_rays: delta");
  expect_shape(background, {R, 3}, "composite_rays: background");
  const auto dtype = sigma.scalar_type();
  FSKIN_CHECK(dtype == torch::kFloat32 || dtype == torch::kFloat64,
              "composite_rays: sigma must be float32 or float64, got {}", c10::toString(dtype));
  for (const auto* t : {&rgb, &delta, &background}) {
    FSKIN_CHECK(t->scalar_type() == dtype, "composite_rays: sigma, rgb, delta and background must share one dtype");
    FSKIN_CHECK(t->device() == sigma.device(), "composite_rays: inputs on different devices");
  }
}

template <typename T>
ray_compositing::CompositeLaunch<T> launch_for(const torch::Tensor& sigma, const torch::Tensor& rgb,
                                               const torch::Tensor& delta, const torch::Tensor& background) {
  ray_compositing::CompositeLaunch<T> a{};
  a.sigma = sigma.data_ptr<T>();
  a.rgb = rgb.data_ptr<T>();
  a.delta = delta.data_ptr<T>();
  a.background = background.data_ptr<T>();
  a.rays = sigma.size(0);
  a.samples = sigma.size(1);
  return a;
}

using CompositeSignature = std::tuple<torch::Tensor, torch::Tensor>(const torch::Tensor&, const torch::Tensor&,
                                                                    const torch::Tensor&, const torch::Tensor&);
using CompositeBackwardSignature = std::tuple<torch::Tensor, torch::Tensor, torch::Tensor, torch::Tensor>(
    const torch::Tensor&, const c10::optional<torch::Tensor>&, const torch::Tensor&, const torch::Tensor&,
    const torch::Tensor&, const torch::Tensor&, std::array<bool, 4>);

}  // namespace

// The CPU and CUDA keys' kernel. One function serves both: the devices share
// the per-ray core and its launch arguments, and run_on_device picks the launch.
std::tuple<torch::Tensor, torch::Tensor> composite_rays_kernel(const torch::Tensor& sigma, const torch::Tensor& rgb,
                                                               const torch::Tensor& delta,
                                                               const torch::Tensor& background) {
  check_inputs(sigma, rgb, delta, background);
  const auto s = sigma.contiguous(), c = rgb.contiguous(), d = delta.contiguous(), b = background.contiguous();
  auto color = torch::empty({s.size(0), 3}, s.options());
  auto opacity = torch::empty({s.size(0)}, s.options());
  if (s.size(0) > 0) {
    AT_DISPATCH_FLOATING_TYPES(s.scalar_type(), "composite_rays", [&] {
      auto a = launch_for<scalar_t>(s, c, d, b);
      a.color = color.data_ptr<scalar_t>();
      a.opacity = opacity.data_ptr<scalar_t>();
      run_on_device(
          s, "composite_rays", [&] { ray_compositing::composite_rays_cpu(a, false); },
          [&](void* stream) { ray_compositing::composite_rays_cuda(a, false, stream); });
    });
  }
  return {color, opacity};
}

namespace {

// The analytic backward (a second front-to-back pass); output_mask says which
// of (sigma, rgb, delta, background) need a gradient, the others come back undefined.
std::tuple<torch::Tensor, torch::Tensor, torch::Tensor, torch::Tensor> composite_rays_backward_kernel(
    const torch::Tensor& grad_color, const c10::optional<torch::Tensor>& grad_opacity, const torch::Tensor& sigma,
    const torch::Tensor& rgb, const torch::Tensor& delta, const torch::Tensor& background,
    std::array<bool, 4> output_mask) {
  check_inputs(sigma, rgb, delta, background);
  const auto s = sigma.contiguous(), c = rgb.contiguous(), d = delta.contiguous(), b = background.contiguous();
  expect_shape(grad_color, {s.size(0), 3}, "composite_rays backward: grad_color");
  const auto gc = grad_color.to(s.options()).contiguous();
  torch::Tensor ga;
  if (grad_opacity && grad_opacity->defined()) {
    expect_shape(*grad_opacity, {s.size(0)}, "composite_rays backward: grad_opacity");
    ga = grad_opacity->to(s.options()).contiguous();
  }
  torch::Tensor grad_sigma, grad_rgb, grad_delta, grad_background;
  if (output_mask[0]) grad_sigma = torch::empty_like(s);
  if (output_mask[1]) grad_rgb = torch::empty_like(c);
  if (output_mask[2]) grad_delta = torch::empty_like(d);
  if (output_mask[3]) grad_background = torch::empty_like(b);
  const bool any = output_mask[0] || output_mask[1] || output_mask[2] || output_mask[3];
  if (s.size(0) > 0 && any) {
    AT_DISPATCH_FLOATING_TYPES(s.scalar_type(), "composite_rays backward", [&] {
      auto a = launch_for<scalar_t>(s, c, d, b);
      a.grad_color = gc.data_ptr<scalar_t>();
      a.grad_opacity = ga.defined() ? ga.data_ptr<scalar_t>() : nullptr;
      const auto pointer = [](torch::Tensor& t) { return t.defined() ? t.data_ptr<scalar_t>() : nullptr; };
      a.grad_sigma = pointer(grad_sigma);
      a.grad_rgb = pointer(grad_rgb);
      a.grad_delta = pointer(grad_delta);
      a.grad_background = pointer(grad_background);
      run_on_device(
          s, "composite_rays backward", [&] { ray_compositing::composite_rays_cpu(a, true); },
          [&](void* stream) { ray_compositing::composite_rays_cuda(a, true, stream); });
    });
  }
  return {grad_sigma, grad_rgb, grad_delta, grad_background};
}

// The Autograd key: records the graph and calls the device kernels below it
// (as torchvision's ops/autograd/ do), so the backward runs the op's own kernel.
class CompositeFunction : public torch::autograd::Function<CompositeFunction> {
 public:
  static torch::autograd::tensor_list forward(torch::autograd::AutogradContext* ctx, const torch::Tensor& sigma,
                                              const torch::Tensor& rgb, const torch::Tensor& delta,
                                              const torch::Tensor& background) {
    ctx->save_for_backward({sigma, rgb, delta, background});
    at::AutoDispatchBelowADInplaceOrView below_autograd;
    static const auto op = fskin_operator<CompositeSignature>("fskin::composite_rays");
    const auto [color, opacity] = op.call(sigma, rgb, delta, background);
    return {color, opacity};
  }

  static torch::autograd::tensor_list backward(torch::autograd::AutogradContext* ctx,
                                               torch::autograd::tensor_list grad_outputs) {
    const auto saved = ctx->get_saved_variables();
    const auto& s = saved[0];
    const auto grad_color = grad_outputs[0].defined() ? grad_outputs[0] : torch::zeros({s.size(0), 3}, s.options());
    const c10::optional<torch::Tensor> grad_opacity =
        grad_outputs[1].defined() ? c10::optional<torch::Tensor>(grad_outputs[1]) : c10::nullopt;
    static const auto op = fskin_operator<CompositeBackwardSignature>("fskin::_composite_rays_backward");
    const auto [grad_sigma, grad_rgb, grad_delta, grad_background] =
        op.call(grad_color, grad_opacity, s, saved[1], saved[2], saved[3],
                {ctx->needs_input_grad(0), ctx->needs_input_grad(1), ctx->needs_input_grad(2),
                 ctx->needs_input_grad(3)});
    return {grad_sigma, grad_rgb, grad_delta, grad_background};
  }
};

std::tuple<torch::Tensor, torch::Tensor> composite_rays_autograd(const torch::Tensor& sigma, const torch::Tensor& rgb,
                                                                 const torch::Tensor& delta,
                                                                 const torch::Tensor& background) {
  const auto out = CompositeFunction::apply(sigma, rgb, delta, background);
  return {out[0], out[1]};
}

// The backward op under Autograd. The analytic backward has no derivative of
// its own: differentiating it (create_graph) is an error here, not gradients
// that silently stop; otherwise the kernel runs below autograd.
std::tuple<torch::Tensor, torch::Tensor, torch::Tensor, torch::Tensor> composite_rays_backward_autograd(
    const torch::Tensor& grad_color, const c10::optional<torch::Tensor>& grad_opacity, const torch::Tensor& sigma,
    const torch::Tensor& rgb, const torch::Tensor& delta, const torch::Tensor& background,
    std::array<bool, 4> output_mask) {
  const bool differentiated = grad_color.requires_grad() || (grad_opacity && grad_opacity->requires_grad()) ||
                              sigma.requires_grad() || rgb.requires_grad() || delta.requires_grad() ||
                              background.requires_grad();
  FSKIN_CHECK(!(torch::GradMode::is_enabled() && differentiated),
              "composite_rays: double backward (create_graph=True) is not supported");
  at::AutoDispatchBelowADInplaceOrView below_autograd;
  static const auto op = fskin_operator<CompositeBackwardSignature>("fskin::_composite_rays_backward");
  return op.call(grad_color, grad_opacity, sigma, rgb, delta, background, output_mask);
}

}  // namespace

TORCH_LIBRARY_FRAGMENT(fskin, m) {
  m.def("composite_rays(Tensor sigma, Tensor rgb, Tensor delta, Tensor background) -> (Tensor color, Tensor opacity)");
  m.def(
      "_composite_rays_backward(Tensor grad_color, Tensor? grad_opacity, Tensor sigma, Tensor rgb, Tensor delta, "
      "Tensor background, bool[4] output_mask) -> (Tensor, Tensor, Tensor, Tensor)");
}

TORCH_LIBRARY_IMPL(fskin, CPU, m) {
  m.impl("composite_rays", TORCH_FN(composite_rays_kernel));
  m.impl("_composite_rays_backward", TORCH_FN(composite_rays_backward_kernel));
}

#ifdef FSKIN_WITH_CUDA
TORCH_LIBRARY_IMPL(fskin, CUDA, m) {
  m.impl("composite_rays", TORCH_FN(composite_rays_kernel));
  m.impl("_composite_rays_backward", TORCH_FN(composite_rays_backward_kernel));
}
#endif

TORCH_LIBRARY_IMPL(fskin, Autograd, m) {
  m.impl("composite_rays", TORCH_FN(composite_rays_autograd));
  m.impl("_composite_rays_backward", TORCH_FN(composite_rays_backward_autograd));
}

std::tuple<torch::Tensor, torch::Tensor> composite_rays(const torch::Tensor& sigma, const torch::Tensor& rgb,
                                                        const torch::Tensor& delta, const torch::Tensor& background) {
  // Shapes, dtypes and devices are the kernel's to check (every caller of the op passes there).
  expect_finite_on_cpu(delta, "composite_rays: delta");
  static const auto op = fskin_operator<CompositeSignature>("fskin::composite_rays");
  return op.call(sigma, rgb, delta, background);
}

std::tuple<torch::Tensor, torch::Tensor> composite_rays_reference(const torch::Tensor& sigma, const torch::Tensor& rgb,
                                                                  const torch::Tensor& delta,
                                                                  const torch::Tensor& background) {
  check_inputs(sigma, rgb, delta, background);
  const auto keep = torch::exp(-sigma * delta);  // 1 - alpha
  // T_s = prod_{k<s} keep_k: an exclusive cumulative product.
  const auto ones = torch::ones({sigma.size(0), 1}, sigma.options());
  const auto transmittance = torch::cumprod(torch::cat({ones, keep}, 1), 1);
  const auto weights = transmittance.narrow(1, 0, sigma.size(1)) * (1 - keep);
  const auto final_transmittance = transmittance.select(1, sigma.size(1));
  const auto color = (weights.unsqueeze(-1) * rgb).sum(1) + final_transmittance.unsqueeze(-1) * background;
  return {color, 1 - final_transmittance};
}

}  // namespace fskin

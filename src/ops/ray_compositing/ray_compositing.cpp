// composite_rays: validates the inputs, fills the raw launch arguments,
// dispatches on device and dtype, and wires forward and backward into
// autograd. Also the LibTorch reference of the same compositing.
#include "fskin/ops/ray_compositing.h"

#include <torch/torch.h>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
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

class CompositeFunction : public torch::autograd::Function<CompositeFunction> {
 public:
  static torch::autograd::tensor_list forward(torch::autograd::AutogradContext* ctx, const torch::Tensor& sigma,
                                              const torch::Tensor& rgb, const torch::Tensor& delta,
                                              const torch::Tensor& background) {
    const auto s = sigma.contiguous(), c = rgb.contiguous(), d = delta.contiguous(), b = background.contiguous();
    ctx->save_for_backward({s, c, d, b});
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

  static torch::autograd::tensor_list backward(torch::autograd::AutogradContext* ctx,
                                               torch::autograd::tensor_list grad_outputs) {
    const auto saved = ctx->get_saved_variables();
    const auto &s = saved[0], &c = saved[1], &d = saved[2], &b = saved[3];
    auto grad_color = grad_outputs[0].defined() ? grad_outputs[0].contiguous() : torch::zeros({s.size(0), 3}, s.options());
    const auto grad_opacity = grad_outputs[1].defined() ? grad_outputs[1].contiguous() : torch::Tensor();
    torch::Tensor grad_sigma, grad_rgb, grad_delta, grad_background;
    if (ctx->needs_input_grad(0)) grad_sigma = torch::empty_like(s);
    if (ctx->needs_input_grad(1)) grad_rgb = torch::empty_like(c);
    if (ctx->needs_input_grad(2)) grad_delta = torch::empty_like(d);
    if (ctx->needs_input_grad(3)) grad_background = torch::empty_like(b);
    if (s.size(0) > 0 && (grad_sigma.defined() || grad_rgb.defined() || grad_delta.defined() ||
                          grad_background.defined())) {
      AT_DISPATCH_FLOATING_TYPES(s.scalar_type(), "composite_rays backward", [&] {
        auto a = launch_for<scalar_t>(s, c, d, b);
        a.grad_color = grad_color.data_ptr<scalar_t>();
        a.grad_opacity = grad_opacity.defined() ? grad_opacity.data_ptr<scalar_t>() : nullptr;
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
};

}  // namespace

std::tuple<torch::Tensor, torch::Tensor> composite_rays(const torch::Tensor& sigma, const torch::Tensor& rgb,
                                                        const torch::Tensor& delta, const torch::Tensor& background) {
  check_inputs(sigma, rgb, delta, background);
  expect_finite_on_cpu(delta, "composite_rays: delta");
  const auto out = CompositeFunction::apply(sigma, rgb, delta, background);
  return {out[0], out[1]};
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

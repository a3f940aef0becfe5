// Autograd wiring of the implicit root gradient (SNARF eq. 14, Fast-SNARF eq. 17).
#include "fskin/ops/implicit_gradient.h"

#include <torch/torch.h>

#include "fskin/core/tensor_checks.h"

namespace fskin {

namespace {

class ImplicitRootGradient : public torch::autograd::Function<ImplicitRootGradient> {
 public:
  static torch::Tensor forward(torch::autograd::AutogradContext* ctx, const torch::Tensor& x_root,
                               const torch::Tensor& inverse_jacobian, const torch::Tensor& residual) {
    ctx->save_for_backward({inverse_jacobian});
    return x_root.detach().clone();
  }

  static torch::autograd::tensor_list backward(torch::autograd::AutogradContext* ctx,
                                               torch::autograd::tensor_list grad_outputs) {
    const auto jinv = ctx->get_saved_variables()[0];
    // dx*/dr = -J^-1, so dL/dr = -J^-T dL/dx*.
    const auto grad_residual = -torch::matmul(jinv.transpose(1, 2), grad_outputs[0].unsqueeze(-1)).squeeze(-1);
    return {torch::Tensor(), torch::Tensor(), grad_residual};
  }
};

}  // namespace

torch::Tensor attach_implicit_gradient(const torch::Tensor& x_root, const torch::Tensor& inverse_jacobian,
                                       const torch::Tensor& residual) {
  expect_shape(x_root, {-1, 3}, "attach_implicit_gradient: x_root");
  expect_shape(inverse_jacobian, {x_root.size(0), 3, 3}, "attach_implicit_gradient: inverse_jacobian");
  expect_shape(residual, {x_root.size(0), 3}, "attach_implicit_gradient: residual");
  return ImplicitRootGradient::apply(x_root.detach(), inverse_jacobian.detach().to(residual.dtype()), residual);
}

}  // namespace fskin

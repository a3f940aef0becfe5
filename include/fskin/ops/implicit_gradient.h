#pragma once
// Gradients of roots of d(x) = x' by implicit differentiation (SNARF eq. 12-14,
// Fast-SNARF eq. 12 and 16-17). Given a root x* (no graph), the inverse
// Jacobian J^-1 = (dd/dx at x*)^-1 (exact, or Broyden's last estimate), and the
// residual r = d(x*) - x' computed WITH the graph of everything it depends on
// (field parameters, bones, x'), returns x* whose backward pass is
// dL/dr = -J^-T dL/dx*. So dx*/dtheta = -J^-1 dd/dtheta and dx*/dx' = J^-1.
#include <torch/types.h>

namespace fskin {

// x_root [M, 3], inverse_jacobian [M, 3, 3], residual [M, 3] -> [M, 3] (value x_root).
torch::Tensor attach_implicit_gradient(const torch::Tensor& x_root, const torch::Tensor& inverse_jacobian,
                                       const torch::Tensor& residual);

}  // namespace fskin

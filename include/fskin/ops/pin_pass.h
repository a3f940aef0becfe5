#pragma once
// A PIN (INS eq. 13) or its inverse (eq. 14) as one fused kernel for
// inference: per frame the operation maps' first layers are folded with the
// pose embedding (operation_map.h), packed into one buffer, and every point
// runs all coupling layers in registers (ops/pin_pass/). CPU kernel over
// at::parallel_for, CUDA kernel on CUDA tensors. No gradients: training uses
// PinImpl::forward_embedded / inverse_embedded. The op is
// fskin::pin_pass(points, packed, shape, inverse) in PyTorch's dispatcher
// (ops/common/dispatcher.h). Matches them to ~1e-6 in
// float32 (tests/ops/pin_pass_front_end_test.cpp).
#include <torch/torch.h>

#include <cstdint>
#include <vector>

#include "fskin/invertible/pin.h"

namespace fskin {

// Whether the kernel can run this PIN (<= 64 layers, SIREN and map widths
// <= 256, which every configuration fskin ships meets).
bool fused_pin_pass_supports(const PinImpl& pin);

// The op's arguments for a PIN and pose embeddings [B, E]: the per-frame
// parameters folded and packed, [B, P] float32, and the architecture as
// torch.ops.fskin.pin_pass's int[] shape. Throws fskin::Error on a bad shape,
// a non-finite embedding or an unsupported PIN.
struct FusedPinArguments {
  torch::Tensor packed;
  std::vector<int64_t> shape;
};
FusedPinArguments fused_pin_arguments(PinImpl& pin, const torch::Tensor& pose_embedding);

// points [B, N, 3] float32, pose_embedding [B, E] -> [B, N, 3]: PIN(points)
// or, with `inverse`, PIN^-1(points). Throws fskin::Error on a bad shape, a
// non-finite input or an unsupported PIN.
torch::Tensor fused_pin_pass(PinImpl& pin, const torch::Tensor& points, const torch::Tensor& pose_embedding,
                             bool inverse);

}  // namespace fskin

#pragma once
// Colours for pictures of skinning: one distinct colour per bone, and meshes
// coloured by their skinning weights.
#include <torch/types.h>

namespace fskin {

// [J, 3] uint8: J clearly distinguishable colours. Hues advance by the golden
// angle so neighbouring bone indices (often neighbouring body parts) differ
// strongly; lightness and saturation cycle so that many bones stay apart.
torch::Tensor bone_palette(int64_t num_bones);

// weights [V, J] float -> [V, 3] uint8: each vertex gets the palette colour of
// the bone with the largest weight (a mesh segmented into bone regions).
torch::Tensor color_by_argmax_weight(const torch::Tensor& weights);

// weights [V, J] float -> [V, 3] uint8: weights @ palette, so vertices
// shared between bones show blended colours (smooth skinning boundaries).
torch::Tensor color_by_blended_weights(const torch::Tensor& weights);

}  // namespace fskin

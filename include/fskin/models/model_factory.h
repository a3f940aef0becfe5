#pragma once
// Builds any model from one description (as tiny-cuda-nn builds a component
// from its config): the method and the options of its parts.
#include <cstdint>
#include <memory>

#include "fskin/invertible/pin.h"
#include "fskin/models/forward_skinning_model.h"
#include "fskin/models/method.h"
#include "fskin/models/occupancy_model.h"

namespace fskin {

struct ModelOptions {
  Method method = Method::FastSnarf;
  // The occupancy and skinning networks, the voxel box and the search of the
  // forward-skinning methods (its `method` is derived from `method`); the
  // baselines take their occupancy network and warp-network sizes from it.
  ForwardSkinningModelOptions forward_skinning;
  // INS: the PINs and their relative learning rate.
  PinOptions pin;
  double pin_learning_rate_factor = 0.1;
  // Piecewise rigid: one MLP per bone.
  int64_t part_hidden_dim = 64;
  int64_t part_hidden_layers = 3;
};

std::shared_ptr<OccupancyModel> make_model(const ModelOptions& options);

}  // namespace fskin

#pragma once
// Every model fskin trains, keyed by its name, a config's `model.type` (as
// tiny-cuda-nn keys its components by `otype`): one row per method with what
// it is and how it is built from one description, ModelOptions. A new model
// is a new row; the config schema, `fskin train --method` and the error for an
// unknown type read the names from here.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

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

struct ModelType {
  Method method;
  std::string name;     // model.type
  std::string summary;  // one line: what the model is
  std::shared_ptr<OccupancyModel> (*build)(const ModelOptions& options);
};

// The registry, in the order help texts list it (the default first).
const std::vector<ModelType>& model_types();
// The row named `name`; throws fskin::Error listing the names.
const ModelType& model_type(const std::string& name);
const ModelType& model_type(Method method);

Method parse_method(const std::string& name);  // model_type(name).method
std::string method_name(Method method);
const std::vector<std::string>& method_names();

// model_type(options.method).build(options).
std::shared_ptr<OccupancyModel> make_model(const ModelOptions& options);

}  // namespace fskin

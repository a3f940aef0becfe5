#include "fskin/models/model_registry.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "fskin/core/error.h"
#include "fskin/models/baselines/backward_displacement.h"
#include "fskin/models/baselines/backward_lbs.h"
#include "fskin/models/baselines/piecewise_rigid.h"
#include "fskin/models/baselines/pose_onet.h"
#include "fskin/models/ins_model.h"

namespace fskin {

namespace {

std::shared_ptr<OccupancyModel> build_forward_skinning(const ModelOptions& options) {
  auto forward = options.forward_skinning;
  forward.method = options.method;
  return std::make_shared<ForwardSkinningModel>(forward);
}

std::shared_ptr<OccupancyModel> build_ins(const ModelOptions& options) {
  auto forward = options.forward_skinning;
  forward.method = Method::FastSnarf;  // INS searches its LBS roots with Fast-SNARF's kernel
  return std::make_shared<InsModel>(InsModelOptions{forward, options.pin, options.pin_learning_rate_factor});
}

std::shared_ptr<OccupancyModel> build_pose_onet(const ModelOptions& options) {
  // The pose is the only thing that tells poses apart: always conditioned,
  // at the input layer (SNARF sec. 4.2: "pose concatenated to the input").
  auto occupancy = options.forward_skinning.occupancy;
  occupancy.pose_dim = 3 * (options.forward_skinning.skinning.num_bones - 1);
  occupancy.pose_layer = 0;
  return std::make_shared<PoseOnetModel>(occupancy);
}

// The posed-space warp network is sized like the skinning network.
BackwardWarpOptions warp_options(const ModelOptions& options) {
  const auto& skinning = options.forward_skinning.skinning;
  return {skinning.num_bones, skinning.hidden_dim, skinning.hidden_layers, skinning.input};
}

std::shared_ptr<OccupancyModel> build_back_lbs(const ModelOptions& options) {
  return std::make_shared<BackwardLbsModel>(options.forward_skinning.occupancy, warp_options(options));
}

std::shared_ptr<OccupancyModel> build_back_d(const ModelOptions& options) {
  return std::make_shared<BackwardDisplacementModel>(options.forward_skinning.occupancy, warp_options(options));
}

std::shared_ptr<OccupancyModel> build_piecewise(const ModelOptions& options) {
  PiecewiseRigidOptions parts;
  parts.num_bones = options.forward_skinning.skinning.num_bones;
  parts.hidden_dim = options.part_hidden_dim;
  parts.hidden_layers = options.part_hidden_layers;
  parts.input = options.forward_skinning.skinning.input;
  return std::make_shared<PiecewiseRigidModel>(parts);
}

}  // namespace

const std::vector<ModelType>& model_types() {
  static const std::vector<ModelType> types = {
      {Method::FastSnarf, "fast-snarf", "Fast-SNARF: voxel skinning grid, fused root search", build_forward_skinning},
      {Method::Snarf, "snarf", "SNARF: skinning MLP, exact implicit gradient", build_forward_skinning},
      {Method::PoseOnet, "pose-onet", "baseline: pose-conditioned occupancy in posed space", build_pose_onet},
      {Method::BackLbs, "back-lbs", "baseline: posed-space skinning weights, inverse LBS", build_back_lbs},
      {Method::BackD, "back-d", "baseline: posed-space displacement to canonical space", build_back_d},
      {Method::Piecewise, "piecewise", "baseline: rigid parts, one occupancy network per bone", build_piecewise},
      {Method::Ins, "ins", "INS: invertible networks around the LBS, pose-free shape", build_ins},
  };
  return types;
}

const std::vector<std::string>& method_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n;
    for (const auto& type : model_types()) n.push_back(type.name);
    return n;
  }();
  return names;
}

const ModelType& model_type(const std::string& name) {
  for (const auto& type : model_types())
    if (type.name == name) return type;
  fail("unknown method '{}' (expected one of {})", name, fmt::join(method_names(), ", "));
}

const ModelType& model_type(Method method) {
  for (const auto& type : model_types())
    if (type.method == method) return type;
  fail("model registry: no model type for method {}", static_cast<int>(method));
}

Method parse_method(const std::string& name) { return model_type(name).method; }

std::string method_name(Method method) { return model_type(method).name; }

std::shared_ptr<OccupancyModel> make_model(const ModelOptions& options) { return model_type(options.method).build(options); }

}  // namespace fskin

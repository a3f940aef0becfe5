#include "fskin/models/model_factory.h"

#include "fskin/core/error.h"
#include "fskin/models/baselines/backward_displacement.h"
#include "fskin/models/baselines/backward_lbs.h"
#include "fskin/models/baselines/piecewise_rigid.h"
#include "fskin/models/baselines/pose_onet.h"
#include "fskin/models/ins_model.h"

namespace fskin {

std::shared_ptr<OccupancyModel> make_model(const ModelOptions& options) {
  auto forward = options.forward_skinning;
  const int64_t num_bones = forward.skinning.num_bones;
  switch (options.method) {
    case Method::FastSnarf:
    case Method::Snarf:
      forward.method = options.method;
      return std::make_shared<ForwardSkinningModel>(forward);
    case Method::Ins:
      forward.method = Method::FastSnarf;  // INS searches its LBS roots with Fast-SNARF's kernel
      return std::make_shared<InsModel>(InsModelOptions{forward, options.pin, options.pin_learning_rate_factor});
    case Method::PoseOnet: {
      // The pose is the only thing that tells poses apart: always conditioned,
      // at the input layer (SNARF sec. 4.2: "pose concatenated to the input").
      auto occupancy = forward.occupancy;
      occupancy.pose_dim = 3 * (num_bones - 1);
      occupancy.pose_layer = 0;
      return std::make_shared<PoseOnetModel>(occupancy);
    }
    case Method::BackLbs:
    case Method::BackD: {
      // The posed-space warp network is sized like the skinning network.
      const BackwardWarpOptions warp{num_bones, forward.skinning.hidden_dim, forward.skinning.hidden_layers,
                                     forward.skinning.input};
      if (options.method == Method::BackLbs) return std::make_shared<BackwardLbsModel>(forward.occupancy, warp);
      return std::make_shared<BackwardDisplacementModel>(forward.occupancy, warp);
    }
    case Method::Piecewise: {
      PiecewiseRigidOptions parts;
      parts.num_bones = num_bones;
      parts.hidden_dim = options.part_hidden_dim;
      parts.hidden_layers = options.part_hidden_layers;
      parts.input = forward.skinning.input;
      return std::make_shared<PiecewiseRigidModel>(parts);
    }
  }
  fail("make_model: unknown method {}", static_cast<int>(options.method));
}

}  // namespace fskin

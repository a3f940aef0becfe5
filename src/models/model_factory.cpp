#include "fskin/training/model_factory.h"

#include "fskin/baselines/backward_displacement.h"
#include "fskin/baselines/backward_lbs.h"
#include "fskin/baselines/piecewise_rigid.h"
#include "fskin/baselines/pose_onet.h"
#include "fskin/core/error.h"
#include "fskin/training/articulated_occupancy_model.h"

namespace fskin {

std::shared_ptr<OccupancyModel> make_model(const TrainConfig& config, const CanonicalSkeleton& skeleton) {
  const auto options = model_options(config, skeleton);  // validates the config
  const int64_t num_bones = options.skinning.num_bones;
  switch (options.method) {
    case Method::FastSnarf:
    case Method::Snarf:
    case Method::Ins:
      return std::make_shared<ArticulatedOccupancyModel>(options);
    case Method::PoseOnet: {
      // The pose is the only thing that tells poses apart: always conditioned,
      // at the input layer (SNARF sec. 4.2: "pose concatenated to the input").
      auto occupancy = options.occupancy;
      occupancy.pose_dim = 3 * (num_bones - 1);
      occupancy.pose_layer = 0;
      return std::make_shared<PoseOnetModel>(occupancy);
    }
    case Method::BackLbs:
    case Method::BackD: {
      // The posed-space warp network is sized like the skinning network.
      const BackwardWarpOptions warp{num_bones, config.skinning_hidden_dim, config.skinning_hidden_layers,
                                     options.skinning.input};
      if (options.method == Method::BackLbs) return std::make_shared<BackwardLbsModel>(options.occupancy, warp);
      return std::make_shared<BackwardDisplacementModel>(options.occupancy, warp);
    }
    case Method::Piecewise: {
      PiecewiseRigidOptions parts;
      parts.num_bones = num_bones;
      parts.hidden_dim = config.part_hidden_dim;
      parts.hidden_layers = config.part_hidden_layers;
      parts.input = options.skinning.input;
      return std::make_shared<PiecewiseRigidModel>(parts);
    }
  }
  fail("train: unknown method '{}'", config.method);
}

}  // namespace fskin

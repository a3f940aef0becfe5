#pragma once
// Invertible Neural Skinning (INS sec. 3.3, eq. 16): two pose-conditioned
// invertible networks around the differentiable LBS of a forward-skinning
// model with Fast-SNARF's search. A posed point x' goes through PIN_d, the
// Broyden search finds its LBS roots, PIN_c maps them to the pose-free
// canonical space where the occupancy network lives. Re-posing (eq. 19) runs
// the chain backwards on canonical points: PIN_c^-1, forward LBS, PIN_d^-1,
// so one canonical mesh is re-posed with exact vertex correspondences.
#include <torch/torch.h>

#include "fskin/invertible/pin.h"
#include "fskin/invertible/pose_encoding.h"
#include "fskin/models/forward_skinning_model.h"

namespace fskin {

struct InsModelOptions {
  // The occupancy network (pose-free: pose_dim = 0), the skinning network and
  // the Fast-SNARF search (method must be FastSnarf).
  ForwardSkinningModelOptions lbs;
  // The two PINs (sharing one pose encoder, pin.pose) and their learning rate
  // relative to the rest (paper: 1e-4 vs 1e-3).
  PinOptions pin;
  double pin_learning_rate_factor = 0.1;
};

class InsModel : public ForwardSkinningModel {
 public:
  explicit InsModel(const InsModelOptions& options);

  // Canonical points [B, V, 3] -> posed [B, V, 3] for bones [B, J, 4, 4] (eq. 19).
  torch::Tensor repose(const torch::Tensor& x_canonical, const torch::Tensor& bones) override;
  // The occupancy and skinning networks' groups, then the PINs' and the pose
  // encoder's at pin_learning_rate_factor.
  std::vector<ParameterGroup> parameter_groups(double learning_rate) override;

 protected:
  torch::Tensor encode_pose(const torch::Tensor& bones, torch::ScalarType dtype) override;
  torch::Tensor to_search_space(const torch::Tensor& points, const torch::Tensor& pose_embedding) override;
  torch::Tensor to_shape_space(const torch::Tensor& roots, const torch::Tensor& pose_embedding, int64_t b) override;

 private:
  InsModelOptions ins_options_;
  PoseEncoder pose_encoder_{nullptr};
  Pin pin_canonical_{nullptr}, pin_deformed_{nullptr};
  // A PIN applied in the networks' normalised coordinates, so its rotations
  // turn about the body's centre rather than the canonical origin (the feet).
  torch::Tensor through_pin(Pin& pin, const torch::Tensor& x, const torch::Tensor& pose_embedding, bool inverse);
};

}  // namespace fskin

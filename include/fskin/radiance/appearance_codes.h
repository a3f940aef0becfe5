#pragma once
// Per-frame appearance codes (NeRF in the Wild's appearance embeddings, as
// HumanNeRF-style avatars use them for captures whose shading changes from
// frame to frame): a learned vector per training frame (one pose and the
// views that see it) that the radiance field's colour is conditioned on
// (radiance_field.h, appearance_dim). A frame's code can hold what its light
// does to the body in that pose; poses never seen get the codes' mean, which
// training keeps at zero (center()), so the field's colour at code zero is
// the frames' average appearance.
//
// Like pose corrections (pose_correction.h) each frame's code is a parameter
// of its own, so that a step's gradients leave out the frames it does not
// render, and the module keeps the frames' given bones to match the images of
// other splits (novel views of training poses) to their frame.
#include <torch/torch.h>

#include <memory>
#include <vector>

namespace fskin {

class AppearanceCodesImpl : public torch::nn::Module {
 public:
  // given_bones [F, J, 4, 4]: the frames' bones as the dataset gives them;
  // dim: the code length. Codes start as N(0, 0.01^2) draws from torch's
  // generator, centred.
  AppearanceCodesImpl(const torch::Tensor& given_bones, int64_t dim);
  // The module as saved in `archive`.
  static std::shared_ptr<AppearanceCodesImpl> read(torch::serialize::InputArchive& archive);
  int64_t frames() const { return given_.size(0); }
  int64_t dim() const { return dim_; }
  // Frame `frame`'s code [dim], differentiable.
  const torch::Tensor& code(int64_t frame) const;
  // The code of the frame whose given bones equal `bones` [J, 4, 4]; an
  // undefined tensor (the mean appearance) for any other pose.
  torch::Tensor code_for(const torch::Tensor& bones) const;
  // As PoseCorrectionsImpl: drop every frame's gradient before a step's
  // backward; subtract the mean code from every frame (a code every frame
  // shares is indistinguishable from the field's own colour).
  void forget_gradients();
  void center();
  torch::Tensor codes() const;  // [F, dim], detached

 private:
  torch::Tensor given_;
  int64_t dim_ = 0;
  std::vector<torch::Tensor> codes_;
};
TORCH_MODULE(AppearanceCodes);

}  // namespace fskin

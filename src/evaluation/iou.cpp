#include "fskin/evaluation/iou.h"

#include <torch/torch.h>

namespace fskin {

double intersection_over_union(const torch::Tensor& predicted, const torch::Tensor& truth) {
  const double uni = (predicted | truth).sum().item<double>();
  return uni == 0 ? 1.0 : (predicted & truth).sum().item<double>() / uni;
}

}  // namespace fskin

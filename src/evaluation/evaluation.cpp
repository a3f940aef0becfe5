#include "fskin/evaluation/evaluation.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <torch/torch.h>

#include "fskin/core/device.h"
#include "fskin/core/error.h"
#include "fskin/evaluation/iou.h"
#include "fskin/util/free_cores.h"
#include "fskin/util/progress.h"

namespace fskin {

EvaluationResult evaluate(OccupancyModel& model, const std::vector<OccupancyFrame>& frames,
                          const std::string& split, int64_t chunk_points, bool progress) {
  FSKIN_CHECK(chunk_points >= 1, "evaluate: chunk_points must be >= 1");
  torch::NoGradGuard no_grad;
  model.train(false);
  model.freeze_for_inference();
  const auto device = module_device(model);  // inputs go there, logits come back
  EvaluationResult result;
  result.split = split;
  ProgressBar bar("eval " + split, static_cast<int64_t>(frames.size()), progress);
  for (size_t f = 0; f < frames.size(); ++f) {
    follow_free_cores();
    const auto& frame = frames[f];
    FSKIN_CHECK(frame.points.dim() == 2 && frame.points.size(1) == 3 &&
                    frame.occupancy.size(0) == frame.points.size(0) && frame.num_uniform >= 0 &&
                    frame.num_uniform <= frame.points.size(0),
                "evaluate: frame {} has inconsistent points/occupancy/num_uniform", f);
    FrameMetrics m;
    m.frame = static_cast<int64_t>(f);
    m.points = frame.points.size(0);
    const auto bones = frame.bone_transforms.to(device, torch::kFloat32).unsqueeze(0);
    const auto pose = frame.pose.to(device, torch::kFloat32).unsqueeze(0);
    std::vector<torch::Tensor> logits;
    double valid_sum = 0;
    for (int64_t begin = 0; begin < m.points; begin += chunk_points) {
      const auto chunk = frame.points.narrow(0, begin, std::min(chunk_points, m.points - begin));
      auto p = model.predict(chunk.to(device, torch::kFloat32).unsqueeze(0), bones, pose, Aggregation::Max);
      logits.push_back(p.logits.squeeze(0).cpu());
      m.deformer_seconds += p.deformer_seconds;
      m.shape_seconds += p.shape_seconds;
      m.aggregation_seconds += p.aggregation_seconds;
      valid_sum += p.deformer.mean_valid * static_cast<double>(chunk.size(0));
    }
    m.mean_valid = m.points > 0 ? valid_sum / static_cast<double>(m.points) : 0;
    const auto predicted = torch::cat(logits) > 0;
    const auto truth = frame.occupancy > 0.5;
    const int64_t u = frame.num_uniform;
    m.iou_bbox = intersection_over_union(predicted.slice(0, 0, u), truth.slice(0, 0, u));
    m.iou_surf = intersection_over_union(predicted.slice(0, u), truth.slice(0, u));
    result.mean_iou_bbox += m.iou_bbox;
    result.mean_iou_surf += m.iou_surf;
    result.deformer_seconds += m.deformer_seconds;
    result.shape_seconds += m.shape_seconds;
    result.aggregation_seconds += m.aggregation_seconds;
    result.frames.push_back(m);
    bar.advance(1, fmt::format("IoU_bbox {:.3f} IoU_surf {:.3f}", m.iou_bbox, m.iou_surf));
  }
  bar.finish();
  if (!frames.empty()) {
    result.mean_iou_bbox /= static_cast<double>(frames.size());
    result.mean_iou_surf /= static_cast<double>(frames.size());
  }
  return result;
}

std::string EvaluationResult::to_json() const {
  nlohmann::json per_frame = nlohmann::json::array();
  for (const auto& m : frames) {
    per_frame.push_back({{"frame", m.frame},
                         {"iou_bbox", m.iou_bbox},
                         {"iou_surf", m.iou_surf},
                         {"points", m.points},
                         {"valid_per_point", m.mean_valid},
                         {"deformer_s", m.deformer_seconds},
                         {"shape_s", m.shape_seconds},
                         {"aggregation_s", m.aggregation_seconds}});
  }
  const nlohmann::json j = {{"split", split},
                            {"frames", frames.size()},
                            {"mean_iou_bbox", mean_iou_bbox},
                            {"mean_iou_surf", mean_iou_surf},
                            {"seconds", {{"deformer", deformer_seconds},
                                         {"shape", shape_seconds},
                                         {"aggregation", aggregation_seconds}}},
                            {"per_frame", per_frame}};
  return j.dump(2) + "\n";
}

std::string EvaluationResult::table() const {
  std::string out = fmt::format("{:>6} {:>9} {:>9} {:>11} {:>9} {:>9}\n", "frame", "IoU_bbox", "IoU_surf",
                                "deformer_s", "shape_s", "aggr_s");
  for (const auto& m : frames) {
    out += fmt::format("{:>6} {:>9.4f} {:>9.4f} {:>11.3f} {:>9.3f} {:>9.3f}\n", m.frame, m.iou_bbox, m.iou_surf,
                       m.deformer_seconds, m.shape_seconds, m.aggregation_seconds);
  }
  out += fmt::format("{:>6} {:>9.4f} {:>9.4f} {:>11.3f} {:>9.3f} {:>9.3f}\n", "all", mean_iou_bbox, mean_iou_surf,
                     deformer_seconds, shape_seconds, aggregation_seconds);
  return out;
}

}  // namespace fskin

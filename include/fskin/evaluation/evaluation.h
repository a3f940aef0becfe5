#pragma once
// Evaluation as in the papers: per frame, IoU_bbox on the uniform half of its
// points and IoU_surf on the near-surface half (gt > 0.5 vs logit > 0, hard
// max over candidates), then the mean over frames; plus where the time goes
// (deformer / shape network / aggregation).
#include <cstdint>
#include <string>
#include <vector>

#include "fskin/evaluation/evaluation_frame.h"
#include "fskin/models/occupancy_model.h"

namespace fskin {

struct FrameMetrics {
  int64_t frame = 0;
  double iou_bbox = 0, iou_surf = 0;
  double deformer_seconds = 0, shape_seconds = 0, aggregation_seconds = 0;
  int64_t points = 0;
  double mean_valid = 0;  // valid correspondences per point
};

struct EvaluationResult {
  std::string split;
  std::vector<FrameMetrics> frames;
  double mean_iou_bbox = 0, mean_iou_surf = 0;
  double deformer_seconds = 0, shape_seconds = 0, aggregation_seconds = 0;  // summed over frames

  std::string to_json() const;
  // A human-readable table: one row per frame, then "all" (mean IoUs, summed seconds).
  std::string table() const;
};

// Evaluates `model` (put in inference mode) on the frames, chunk_points posed
// points at a time.
EvaluationResult evaluate(OccupancyModel& model, const std::vector<OccupancyFrame>& frames,
                          const std::string& split, int64_t chunk_points = 20000, bool progress = false);

}  // namespace fskin

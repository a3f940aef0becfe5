#pragma once
// A trained run evaluated on a split of its dataset, as `fskin eval` and
// `fskin.evaluate()` do it: the chosen checkpoint, the split's frames (the
// first max_frames), IoU_bbox / IoU_surf and timing per frame, and the JSON
// record written beside the run (eval-SPLIT.json). One implementation for the
// CLI and the Python module.
#include <string>

#include "fskin/evaluation/evaluation.h"

namespace fskin {

struct RunEvaluationRequest {
  std::string run;                    // run directory
  std::string split = "test-within";  // test-within, test-ood, val or train
  std::string data;                   // empty: the dataset the run trained on
  std::string checkpoint = "latest";  // latest, best or a step
  int64_t max_frames = -1;            // < 0: all
  bool progress = true;
  bool write_json = true;             // RUN/eval-SPLIT.json
  std::string device = "cpu";         // cpu, cuda or cuda:N (core/device.h)
};

struct RunEvaluation {
  EvaluationResult metrics;
  std::string method, checkpoint, json_path;
  int64_t step = 0;
  std::string json;  // the record (also written when write_json)
};

RunEvaluation evaluate_run(const RunEvaluationRequest& request);

}  // namespace fskin

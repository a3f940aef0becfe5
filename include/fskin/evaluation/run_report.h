#pragma once
// Several training runs side by side (the analogue of SNARF Table 1 /
// Fast-SNARF Table 1): method, training cost, IoU per test split, and where
// the evaluation time goes, read from what `fskin train` and `fskin eval`
// wrote into each run directory.
#include <map>
#include <string>
#include <vector>

namespace fskin {

struct SplitSummary {
  double iou_bbox = 0, iou_surf = 0;
  int64_t frames = 0;
  // Mean seconds per evaluated frame.
  double deformer_seconds = 0, shape_seconds = 0, aggregation_seconds = 0;
};

struct RunSummary {
  std::string run_dir, method;
  int64_t steps = 0;            // training steps logged
  double train_seconds = 0;     // summed step times
  double seconds_per_step = 0;  // median step time
  std::map<std::string, SplitSummary> splits;  // "test-within", "test-ood", ... (those evaluated)
};

// Reads config.json, log.jsonl and eval-*.json of a run; throws fskin::Error
// naming the file when one is missing or malformed (eval files are optional).
RunSummary summarize_run(const std::string& run_dir);

// A Markdown table, one row per run.
std::string comparison_table(const std::vector<RunSummary>& runs);
// The same data as JSON.
std::string comparison_json(const std::vector<RunSummary>& runs);

}  // namespace fskin

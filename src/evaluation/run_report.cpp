#include "fskin/evaluation/run_report.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <filesystem>
#include <sstream>

#include "fskin/core/error.h"
#include "fskin/engine/run_directory.h"
#include "fskin/util/atomic_file.h"

namespace fskin {

namespace fs = std::filesystem;

namespace {

nlohmann::json parse_json(const std::string& path) {
  try {
    return nlohmann::json::parse(read_file(path));
  } catch (const nlohmann::json::exception& e) {
    fail("{}: not valid JSON ({})", path, e.what());
  }
}

const std::vector<std::string>& report_splits() {
  static const std::vector<std::string> splits = {"test-within", "test-ood"};
  return splits;
}

}  // namespace

RunSummary summarize_run(const std::string& run_dir) {
  FSKIN_CHECK(fs::is_directory(run_dir), "report: {} is not a run directory", run_dir);
  RunSummary r;
  r.run_dir = run_dir;
  const auto config = parse_json(RunDirectory(run_dir).config_file());
  r.method = config.value("method", "?");

  const auto log_path = RunDirectory(run_dir).log_file();
  std::istringstream log(read_file(log_path));
  std::vector<double> step_seconds;
  for (std::string line; std::getline(log, line);) {
    if (line.empty()) continue;
    try {
      step_seconds.push_back(nlohmann::json::parse(line).at("seconds").get<double>());
    } catch (const nlohmann::json::exception& e) {
      fail("{}: line {} is not a log record ({})", log_path, step_seconds.size() + 1, e.what());
    }
  }
  r.steps = static_cast<int64_t>(step_seconds.size());
  for (double s : step_seconds) r.train_seconds += s;
  if (!step_seconds.empty()) {
    auto sorted = step_seconds;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    r.seconds_per_step = sorted[sorted.size() / 2];
  }

  for (const auto& split : report_splits()) {
    const auto path = (fs::path(run_dir) / ("eval-" + split + ".json")).string();
    if (!fs::exists(path)) continue;
    const auto j = parse_json(path);
    SplitSummary s;
    try {
      s.iou_bbox = j.at("mean_iou_bbox").get<double>();
      s.iou_surf = j.at("mean_iou_surf").get<double>();
      s.frames = j.at("frames").get<int64_t>();
      const double n = std::max<int64_t>(s.frames, 1);
      s.deformer_seconds = j.at("seconds").at("deformer").get<double>() / n;
      s.shape_seconds = j.at("seconds").at("shape").get<double>() / n;
      s.aggregation_seconds = j.at("seconds").at("aggregation").get<double>() / n;
    } catch (const nlohmann::json::exception& e) {
      fail("{}: not an evaluation result ({})", path, e.what());
    }
    r.splits[split] = s;
  }
  return r;
}

std::string comparison_table(const std::vector<RunSummary>& runs) {
  std::string out =
      "| run | method | steps | s/step | train min | within IoU_bbox | within IoU_surf | OOD IoU_bbox | "
      "OOD IoU_surf | eval s/frame (deform / shape / aggr) |\n"
      "|---|---|---:|---:|---:|---:|---:|---:|---:|---|\n";
  auto iou = [](const RunSummary& r, const std::string& split, bool surf) {
    const auto it = r.splits.find(split);
    if (it == r.splits.end()) return std::string("-");
    return fmt::format("{:.3f}", surf ? it->second.iou_surf : it->second.iou_bbox);
  };
  for (const auto& r : runs) {
    std::string timing = "-";
    const auto it = r.splits.count("test-ood") ? r.splits.find("test-ood") : r.splits.find("test-within");
    if (it != r.splits.end()) {
      timing = fmt::format("{:.3f} / {:.3f} / {:.3f}", it->second.deformer_seconds, it->second.shape_seconds,
                           it->second.aggregation_seconds);
    }
    out += fmt::format("| {} | {} | {} | {:.2f} | {:.1f} | {} | {} | {} | {} | {} |\n",
                       fs::path(r.run_dir).filename().string(), r.method, r.steps, r.seconds_per_step,
                       r.train_seconds / 60.0, iou(r, "test-within", false), iou(r, "test-within", true),
                       iou(r, "test-ood", false), iou(r, "test-ood", true), timing);
  }
  return out;
}

std::string comparison_json(const std::vector<RunSummary>& runs) {
  nlohmann::json rows = nlohmann::json::array();
  for (const auto& r : runs) {
    nlohmann::json splits = nlohmann::json::object();
    for (const auto& [name, s] : r.splits) {
      splits[name] = {{"iou_bbox", s.iou_bbox},
                      {"iou_surf", s.iou_surf},
                      {"frames", s.frames},
                      {"deformer_s_per_frame", s.deformer_seconds},
                      {"shape_s_per_frame", s.shape_seconds},
                      {"aggregation_s_per_frame", s.aggregation_seconds}};
    }
    rows.push_back({{"run", r.run_dir},
                    {"method", r.method},
                    {"steps", r.steps},
                    {"train_seconds", r.train_seconds},
                    {"seconds_per_step", r.seconds_per_step},
                    {"splits", splits}});
  }
  return rows.dump(2) + "\n";
}

}  // namespace fskin

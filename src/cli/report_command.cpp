// fskin report: trained and evaluated runs side by side, as a Markdown table.
#include <cstdio>

#include "cli/commands.h"
#include "fskin/evaluation/run_report.h"
#include "fskin/util/atomic_file.h"

namespace fskin::cli {

void register_report(CLI::App& app) {
  struct Options {
    std::vector<std::string> runs;
    std::string out, json;
  };
  auto opt = std::make_shared<Options>();
  auto* cmd = app.add_subcommand(
      "report", "Put runs side by side: method, training time, IoU within / OOD, evaluation time split");
  cmd->add_option("runs", opt->runs, "run directories (trained, and evaluated with fskin eval)")->required();
  cmd->add_option("--out", opt->out, "also write the table to this Markdown file");
  cmd->add_option("--json", opt->json, "also write the numbers to this JSON file");
  cmd->callback([opt] {
    std::vector<RunSummary> runs;
    for (const auto& dir : opt->runs) runs.push_back(summarize_run(dir));
    const auto table = comparison_table(runs);
    std::printf("%s", table.c_str());
    if (!opt->out.empty()) write_file_atomically(opt->out, table);
    if (!opt->json.empty()) write_file_atomically(opt->json, comparison_json(runs));
  });
}

}  // namespace fskin::cli

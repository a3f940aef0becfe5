// fskin config show: the full resolved config of a run, or a method's defaults.
#include <cstdio>
#include <filesystem>

#include <nlohmann/json.hpp>

#include "cli/commands.h"
#include "fskin/core/error.h"
#include "fskin/engine/run_directory.h"
#include "fskin/gaussians/gaussian_config.h"
#include "fskin/radiance/avatar_config.h"
#include "fskin/training/train_config.h"
#include "fskin/util/atomic_file.h"

namespace fskin::cli {

void register_config(CLI::App& app) {
  struct Options {
    std::string target;
    bool full = false;
    std::vector<std::string> settings;
  };
  auto opt = std::make_shared<Options>();
  auto* config = app.add_subcommand("config", "Configs: the resolved config of a run or of a method");
  config->require_subcommand(1);
  auto* show = config->add_subcommand(
      "show", "Print the full resolved config (JSON) of a run directory, or the defaults of a method");
  show->add_option("target", opt->target,
                   "a run directory (fskin train / fskin avatar train) or a method: fast-snarf, snarf, ins, "
                   "pose-onet, back-lbs, back-d, piecewise")
      ->required();
  show->add_flag("--full", opt->full, "a method's full-size (paper) config instead of the CPU defaults");
  show->add_option("--set", opt->settings, "key=value applied to a method's defaults, as fskin train --set");
  show->callback([opt] {
    namespace fs = std::filesystem;
    if (fs::is_directory(opt->target)) {
      FSKIN_CHECK(!opt->full && opt->settings.empty(), "config show {}: --full and --set apply to methods, not runs",
                  opt->target);
      const RunDirectory run(opt->target);
      if (fs::exists(run.config_file())) {
        // Through the loader: keys older runs lack come out with the values they trained with.
        std::printf("%s\n", nlohmann::json::parse(TrainConfig::load_run(run.config_file()).to_json()).dump(2).c_str());
        return;
      }
      if (fs::exists(run.gaussian_avatar_config_file())) {
        const auto options = read_gaussian_run_config(run.gaussian_avatar_config_file(), run.path());
        std::printf("%s\n", gaussian_run_document(options).dump(2).c_str());
        return;
      }
      FSKIN_CHECK(fs::exists(run.avatar_config_file()),
                  "{}: not a run directory (no config.json, avatar.json or gaussian_avatar.json)", opt->target);
      // Through the loader too: an avatar run written flat comes out nested.
      const auto options = read_avatar_run_config(run.avatar_config_file(), run.path());
      std::printf("%s\n", avatar_run_document(options).dump(2).c_str());
      return;
    }
    TrainConfig c = opt->full ? TrainConfig::full() : TrainConfig{};
    c.use_method(opt->target);
    for (const auto& s : opt->settings) c.set(s);
    c.validate();
    std::printf("%s\n", nlohmann::json::parse(c.to_json()).dump(2).c_str());
  });
}

}  // namespace fskin::cli

// fskin config show: a method's resolved defaults, a run's config, and errors
// that name what is wrong.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "cli/cli_process.h"
#include "fskin/util/atomic_file.h"
#include "test_util.h"

namespace fskin {
namespace {

namespace fs = std::filesystem;

// Runs `fskin args`; returns its exit code, the output in `output`.
int run_cli(const std::vector<std::string>& args, std::string& output) {
  const auto log = testing::temp_dir("config_command") / "out.txt";
  const int code = testing::wait_exit(testing::spawn_cli(args, log));
  output = read_file(log.string());
  return code;
}

TEST(ConfigCommand, ShowsAMethodsResolvedDefaults) {
  std::string out;
  ASSERT_EQ(run_cli({"config", "show", "ins", "--set", "steps=77"}, out), 0) << out;
  const auto config = nlohmann::json::parse(out);
  EXPECT_EQ(config.at("model").at("type"), "ins");
  EXPECT_EQ(config.at("optimizer").at("grad_clip").get<double>(), 4.0);  // use_method("ins")
  EXPECT_EQ(config.at("steps").get<int64_t>(), 77);
  ASSERT_EQ(run_cli({"config", "show", "fast-snarf", "--full"}, out), 0) << out;
  EXPECT_GT(nlohmann::json::parse(out).at("steps").get<int64_t>(), 1000);  // the paper's schedule
}

TEST(ConfigCommand, ShowsARunsConfigAndRefusesOtherFolders) {
  const auto run = testing::temp_dir("config_command_run");
  // A flat config, as run directories written before the nested layout hold.
  write_file_atomically((run / "config.json").string(), R"({"method": "snarf", "steps": 12})");
  std::string out;
  ASSERT_EQ(run_cli({"config", "show", run.string()}, out), 0) << out;
  const auto config = nlohmann::json::parse(out);
  EXPECT_EQ(config.at("model").at("type"), "snarf");
  EXPECT_EQ(config.at("steps").get<int64_t>(), 12);
  EXPECT_TRUE(config.at("optimizer").contains("learning_rate"));  // every key, resolved, nested

  const auto empty = testing::temp_dir("config_command_empty");
  EXPECT_NE(run_cli({"config", "show", empty.string()}, out), 0);
  EXPECT_NE(out.find("not a run directory"), std::string::npos) << out;
  EXPECT_NE(run_cli({"config", "show", "no-such-method"}, out), 0);
  EXPECT_NE(out.find("no-such-method"), std::string::npos) << out;
}

}  // namespace
}  // namespace fskin

#include "fskin/util/runtime_restart.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <memory>
#include <string>

#include "fskin/util/openmp_wait.h"

namespace fskin {
namespace {

TEST(OpenMpWait, ShortSpinUnlessTheUserChoseAWaitPolicy) {
  EXPECT_EQ(openmp_spin_setting(nullptr, nullptr), std::string(kOpenMpSpinCount));
  EXPECT_FALSE(openmp_spin_setting("300000", nullptr).has_value());
  EXPECT_FALSE(openmp_spin_setting(nullptr, "ACTIVE").has_value());
  EXPECT_FALSE(openmp_spin_setting(nullptr, "passive").has_value());
}

TEST(RuntimeRestart, LongRunningCommandsAreRecognised) {
  auto check = [](std::vector<std::string> words) {
    std::vector<char*> argv;
    for (auto& w : words) argv.push_back(w.data());
    return is_long_running_command(static_cast<int>(argv.size()), argv.data());
  };
  EXPECT_TRUE(check({"fskin", "train", "--data", "d"}));
  EXPECT_TRUE(check({"fskin", "--threads", "2", "eval", "run"}));
  EXPECT_TRUE(check({"fskin", "bench", "deform"}));
  EXPECT_FALSE(check({"fskin", "--version"}));
  EXPECT_FALSE(check({"fskin", "character", "--out", "m.npz"}));
  EXPECT_FALSE(check({"fskin"}));
}

std::string run(const std::string& command) {
  std::unique_ptr<FILE, int (*)(FILE*)> pipe(popen(command.c_str(), "r"), pclose);
  std::string out;
  if (!pipe) return out;
  char buffer[512];
  while (std::fgets(buffer, sizeof buffer, pipe.get()) != nullptr) out += buffer;
  return out;
}

// End to end: a long-running command ends up with the short spin unless the
// user set a policy, which it keeps.
TEST(RuntimeRestart, TheCliRunsLongCommandsWithTheShortSpinAndKeepsTheUsers) {
  const std::string bench = std::string(FSKIN_CLI_PATH) +
                            " bench deform --points 2000 --repeat 1 --pose natural --resolution 40";
  const auto ours = run("env -u GOMP_SPINCOUNT -u OMP_WAIT_POLICY " + bench + " 2>&1");
  EXPECT_NE(ours.find(std::string("GOMP_SPINCOUNT=") + kOpenMpSpinCount + " OMP_WAIT_POLICY=(unset)"),
            std::string::npos)
      << ours;
  const auto users = run("env -u GOMP_SPINCOUNT OMP_WAIT_POLICY=PASSIVE " + bench + " 2>&1");
  EXPECT_NE(users.find("GOMP_SPINCOUNT=(unset) OMP_WAIT_POLICY=PASSIVE"), std::string::npos) << users;
}

}  // namespace
}  // namespace fskin

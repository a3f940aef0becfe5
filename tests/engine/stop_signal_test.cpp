#include "fskin/engine/stop_signal.h"

#include <gtest/gtest.h>

#include <csignal>

namespace fskin {
namespace {

TEST(StopSignal, FirstSigintOnlyRaisesTheFlag) {
  StopSignal stop;
  EXPECT_FALSE(stop.requested());
  std::raise(SIGINT);  // would kill the test process without the handler
  EXPECT_TRUE(stop.requested());
}

TEST(StopSignal, FlagResetsForANewScope) {
  { StopSignal first; StopSignal::request(); EXPECT_TRUE(first.requested()); }
  StopSignal second;
  EXPECT_FALSE(second.requested());
}

}  // namespace
}  // namespace fskin

// The per-point duplicate filter, called directly on plain arrays.
#include "ops/filter_duplicate_roots/filter_duplicate_roots_core.h"

#include <gtest/gtest.h>

namespace fskin::kernels {
namespace {

TEST(FilterDuplicateRootsCore, DropsDuplicateRootsKeepingTheFirst) {
  const double x[12] = {0, 0, 0, 1, 1, 1, 0, 0, 5e-5, 1, 1, 1.5};
  bool valid[4] = {false, true, true, true};
  drop_duplicate_roots(x, valid, 4, 1e-8);  // invalid 0 does not absorb 2
  EXPECT_TRUE(valid[1]);
  EXPECT_TRUE(valid[2]);
  EXPECT_TRUE(valid[3]);
  bool valid2[4] = {true, true, true, true};
  drop_duplicate_roots(x, valid2, 4, 1e-8);
  EXPECT_TRUE(valid2[0]);
  EXPECT_TRUE(valid2[1]);
  EXPECT_FALSE(valid2[2]);
  EXPECT_TRUE(valid2[3]);
}

}  // namespace
}  // namespace fskin::kernels

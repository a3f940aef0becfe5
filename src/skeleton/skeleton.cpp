#include "fskin/skeleton/skeleton.h"

#include <torch/torch.h>

#include <set>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"

namespace fskin {

int64_t Skeleton::find(const std::string& name) const {
  for (size_t j = 0; j < joint_names.size(); ++j)
    if (joint_names[j] == name) return static_cast<int64_t>(j);
  return -1;
}

int64_t Skeleton::index_of(const std::string& name) const {
  const int64_t j = find(name);
  FSKIN_CHECK(j >= 0, "skeleton has no joint named '{}'", name);
  return j;
}

std::vector<std::vector<int64_t>> Skeleton::children() const {
  std::vector<std::vector<int64_t>> out(parents.size());
  for (size_t j = 1; j < parents.size(); ++j) out[parents[j]].push_back(static_cast<int64_t>(j));
  return out;
}

void Skeleton::validate(const std::string& context) const {
  const int64_t J = num_joints();
  FSKIN_CHECK(J > 0, "{}: skeleton has zero joints", context);
  FSKIN_CHECK(parents[0] == -1, "{}: joint 0 must be the root (parent -1), got parent {}", context,
              parents[0]);
  for (int64_t j = 1; j < J; ++j)
    FSKIN_CHECK(parents[j] >= 0 && parents[j] < j,
                "{}: joint {} has parent {}; joints must be in topological order "
                "(0 <= parent < joint)",
                context, j, parents[j]);
  FSKIN_CHECK(static_cast<int64_t>(joint_names.size()) == J,
              "{}: {} joint names for {} joints", context, joint_names.size(), J);
  std::set<std::string> unique(joint_names.begin(), joint_names.end());
  FSKIN_CHECK(static_cast<int64_t>(unique.size()) == J, "{}: joint names are not unique", context);
  expect_shape(rest_joints, {J, 3}, context + ": rest joints");
  expect_finite(rest_joints, context + ": rest joints");
}

}  // namespace fskin

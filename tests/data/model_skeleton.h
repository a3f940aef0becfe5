#pragma once
// The canonical skeleton of a body model in its rest pose, with its mesh, as
// a dataset of it would hold it (canonical_skeleton(dataset)), for tests that
// need one without building a dataset.
#include <torch/torch.h>

#include "fskin/body/body_model.h"
#include "fskin/data/canonical_skeleton.h"

namespace fskin::testing {

inline CanonicalSkeleton rest_skeleton(const BodyModel& model) {
  CanonicalSkeleton c;
  c.joint_names = model.data().joint_names;
  c.parents = model.data().parents;
  c.joints = model.skeleton().rest_joints.to(torch::kFloat32);
  c.extent = model.data().v_template;
  c.faces = model.data().faces;
  return c;
}

}  // namespace fskin::testing

#pragma once
// Ground-truth occupancy of points against a triangle mesh that may be open
// (holes) or made of several overlapping closed parts, as real scans and game
// characters are. Ray casting on Embree 3 with signed crossings and a vote
// over several fixed ray directions; see inside_test.cpp for why this is right.
#include <torch/types.h>

#include <memory>

#include "fskin/geometry/mesh.h"

namespace fskin {

class InsideTest {
 public:
  // Builds the ray-tracing hierarchy of `mesh` (faces counter-clockwise seen
  // from outside). Throws fskin::Error if fskin was built without Embree.
  explicit InsideTest(const Mesh& mesh);
  ~InsideTest();
  InsideTest(InsideTest&&) noexcept;
  InsideTest& operator=(InsideTest&&) noexcept;

  // points [N, 3] float -> occupancy [N] uint8 (1 = inside). Parallel over points.
  torch::Tensor contains(const torch::Tensor& points) const;

  // Number of rays cast per point (odd, so the vote has no ties).
  static constexpr int kRays = 7;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// True when this build can run InsideTest (Embree was found at configure time).
bool inside_test_available();

}  // namespace fskin

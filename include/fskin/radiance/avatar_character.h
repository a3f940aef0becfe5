#pragma once
// canonical.npz: the rigged character (skeleton/rigged_mesh.h) of an image
// dataset and of an avatar run: arrays vertices [V, 3], faces [F, 3],
// weights [V, J], joints [J, 3], parents [J], joint_names.
#include <string>

#include "fskin/skeleton/rigged_mesh.h"

namespace fskin {

// Throws fskin::Error naming `path` and the problem for a missing or
// malformed file.
RiggedMesh load_canonical_character(const std::string& path);
void save_canonical_character(const RiggedMesh& character, const std::string& path);

}  // namespace fskin

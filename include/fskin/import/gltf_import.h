#pragma once
// Rigged characters from glTF 2.0 files (.glb / .gltf) through tinygltf
// (imported_character.h says what comes out). The skin is the one of the
// first skinned mesh node; meshes with other skins or none are dropped and
// reported. Weights from every JOINTS_n/WEIGHTS_n set. glTF is in metres with +Y
// up, so nothing is converted. Clips: LINEAR and STEP as specified,
// CUBICSPLINE at its keyframe values.
#include "fskin/import/imported_character.h"

namespace fskin {

ImportedCharacter import_gltf(const std::string& path, const ImportOptions& options = {});

}  // namespace fskin

#pragma once
// assimp in a child process under a time and memory budget. assimp's
// readers are many and old; some crash (RAW), loop without end or allocate
// without end (OFF) on hostile files. Before fskin reads a file with assimp
// in its own process, a forked child reads it with the same flags and checks
// every pointer and index fskin will follow; only a file that passes is read
// for real. The child uses assimp only (no LibTorch: OpenMP pools do not
// survive fork).
#include <assimp/Importer.hpp>
#include <assimp/scene.h>

#include <string>

#include "fskin/import/imported_character.h"

namespace fskin::import_detail {

// The assimp post-processing flags fskin reads with (the probe and the real
// read must agree).
unsigned assimp_read_flags();
// The importer properties fskin reads with.
void configure_assimp(Assimp::Importer& importer);

// Reads `path` with assimp in a child limited to options.assimp_seconds and
// options.assimp_memory_mib; throws fskin::Error naming the file if assimp
// fails, crashes, exceeds the budget, or returns a scene check_assimp_scene
// refuses.
void probe_with_assimp(const std::string& path, const ImportOptions& options);

// Every pointer, count and index fskin's import follows, checked: nodes
// (walked without recursion, at most kMostAssimpNodes), their mesh indices,
// meshes' vertex, face, bone and weight arrays, face indices, animations,
// channels and key arrays. Throws fskin::Error naming `path`.
void check_assimp_scene(const aiScene* scene, const std::string& path);

}  // namespace fskin::import_detail

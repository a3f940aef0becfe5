#include "fskin/import/imported_character.h"

#include <torch/torch.h>

#include <algorithm>
#include <cctype>
#include <filesystem>

#include "fskin/core/error.h"
#include "fskin/import/assimp_import.h"
#include "fskin/import/gltf_import.h"

namespace fskin {

ImportedCharacter import_character(const std::string& path, const ImportOptions& options) {
  auto extension = std::filesystem::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(), [](unsigned char c) { return std::tolower(c); });
  if (extension == ".glb" || extension == ".gltf") return import_gltf(path, options);
  return import_with_assimp(path, options);
}

PoseSet concatenate_clips(const std::vector<ImportedClip>& clips) {
  FSKIN_CHECK(!clips.empty(), "concatenate_clips: no clips");
  PoseSet set;
  std::vector<torch::Tensor> poses, trans, moved;
  const bool any_moved = std::any_of(clips.begin(), clips.end(),
                                     [](const ImportedClip& c) { return c.poses.joint_translations.defined(); });
  int64_t start = 0;
  for (const auto& c : clips) {
    poses.push_back(c.poses.poses);
    trans.push_back(c.poses.trans);
    if (any_moved)
      moved.push_back(c.poses.joint_translations.defined() ? c.poses.joint_translations : torch::zeros_like(c.poses.poses));
    set.clip_names.push_back(c.name);
    set.clip_starts.push_back(start);
    start += c.poses.size();
  }
  set.poses = torch::cat(poses);
  set.trans = torch::cat(trans);
  if (any_moved) set.joint_translations = torch::cat(moved);
  set.joint_names = clips.front().poses.joint_names;
  return set;
}

}  // namespace fskin

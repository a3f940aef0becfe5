#pragma once
// Mesh animations as glTF 2.0 files (.glb binary, or .gltf with the buffer
// embedded as base64), for Blender, three.js and other viewers.
//
// Layout: ONE mesh whose base shape is frame 0 and whose morph targets are
// frames 1..T-1 (position and normal offsets from frame 0); a weights
// animation with STEP interpolation switches on target t-1 alone at time t/fps.
// We chose morph targets over one node per frame (shown by scale animation)
// because viewers then see a single object: Blender imports it as one mesh
// with a shape key per frame on its timeline, three.js as one morphing mesh
// (morph targets live in a texture since r133, so their number is not capped
// at 8), and vertex colours and faces are stored once.
#include <torch/types.h>

#include <string>

namespace fskin {

struct MeshAnimation {
  torch::Tensor faces;   // [F, 3] int64, counter-clockwise seen from outside
  torch::Tensor frames;  // [T, V, 3] float32 vertex positions per frame, metres
  torch::Tensor colors;  // optional [V, 3] uint8 per-vertex colours (undefined if none)
  double fps = 30;

  int64_t num_frames() const { return frames.defined() ? frames.size(0) : 0; }
  // Throws fskin::Error prefixed with `context` for empty or mismatched
  // shapes, wrong dtypes, NaN/inf, face indices out of range or fps <= 0.
  void validate(const std::string& context) const;
};

// Writes `animation` to `path` (.glb or .gltf, by extension) atomically.
void write_gltf_animation(const std::string& path, const MeshAnimation& animation);

// Reads a file in the layout above back (frames = base + weights . targets at
// each keyframe); throws fskin::Error naming `path` for anything else.
MeshAnimation read_gltf_animation(const std::string& path);

}  // namespace fskin

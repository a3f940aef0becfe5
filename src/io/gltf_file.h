#pragma once
// glTF 2.0 files through tinygltf, shared by every fskin reader and writer of
// glTF (mesh animations, skinned characters, import): loading and saving with
// errors that name the file, and typed access to the single binary buffer.
// Internal to src.
#include <tiny_gltf.h>
#include <torch/types.h>

#include <string>
#include <vector>

namespace fskin::gltf {

// true for .glb, false for .gltf; throws fskin::Error for other extensions.
bool is_binary_path(const std::string& path);

// Reads path (.glb or .gltf); throws fskin::Error naming it if unreadable.
tinygltf::Model load(const std::string& path);
// Writes the model atomically (binary: .glb with the buffer inside; else
// .gltf with the buffer embedded as base64).
void save(const std::string& path, tinygltf::Model& model, bool binary);

// Appends typed arrays to the model's single buffer and describes them with
// buffer views and accessors.
class BufferWriter {
 public:
  explicit BufferWriter(tinygltf::Model& model);
  // `bytes` as a new buffer view; starts are 4-byte aligned as glTF requires
  // for vertex attributes. target 0 = not a vertex or index buffer.
  int add_view(const void* bytes, size_t size, int target);
  // float32 [count, components] as an accessor of `type` (VEC3, SCALAR, ...),
  // with the per-component min/max that glTF requires for positions and
  // animation inputs unless `bounds` is false (other attributes, animation
  // outputs, matrices: no use for them).
  int add_floats(const torch::Tensor& values, int type, int target, bool bounds = true);
  int add_accessor(const tinygltf::Accessor& accessor);

 private:
  tinygltf::Model& model_;
};

// Accessor `index` as doubles, `components` per element (normalised integers
// mapped to [0, 1] or [-1, 1]), sparse substitutions applied; checks type,
// counts and bounds with overflow-safe arithmetic, naming `path` and `what`.
std::vector<double> read_accessor(const tinygltf::Model& model, int index, int type, const std::string& path,
                                  const std::string& what);

}  // namespace fskin::gltf

#include "io/gltf_file.h"

#include <torch/torch.h>

#include <cstring>
#include <filesystem>
#include <sstream>

#include "fskin/core/error.h"
#include "fskin/util/atomic_file.h"

namespace fskin::gltf {

bool is_binary_path(const std::string& path) {
  const auto extension = std::filesystem::path(path).extension().string();
  if (extension == ".glb") return true;
  if (extension == ".gltf") return false;
  fail("{}: glTF files must end in .glb (binary) or .gltf (JSON), got '{}'", path, extension);
}

tinygltf::Model load(const std::string& path) {
  FSKIN_CHECK(std::filesystem::exists(path), "{}: no such file", path);
  const bool binary = is_binary_path(path);
  const std::string bytes = read_file(path);
  tinygltf::Model model;
  tinygltf::TinyGLTF gltf;
  std::string error, warning;
  const auto* data = reinterpret_cast<const unsigned char*>(bytes.data());
  const std::string base_dir = std::filesystem::path(path).parent_path().string();
  const bool ok = binary ? gltf.LoadBinaryFromMemory(&model, &error, &warning, data,
                                                     static_cast<unsigned int>(bytes.size()), base_dir)
                         : gltf.LoadASCIIFromString(&model, &error, &warning, bytes.data(),
                                                    static_cast<unsigned int>(bytes.size()), base_dir);
  FSKIN_CHECK(ok, "{}: not a readable glTF file: {}", path, error);
  return model;
}

void save(const std::string& path, tinygltf::Model& model, bool binary) {
  std::ostringstream stream;
  tinygltf::TinyGLTF gltf;
  FSKIN_CHECK(gltf.WriteGltfSceneToStream(&model, stream, /*prettyPrint=*/!binary, binary),
              "{}: glTF serialisation failed", path);
  write_file_atomically(path, stream.str());
}

BufferWriter::BufferWriter(tinygltf::Model& model) : model_(model) { model_.buffers.resize(1); }

int BufferWriter::add_view(const void* bytes, size_t size, int target) {
  auto& data = model_.buffers[0].data;
  data.resize((data.size() + 3) / 4 * 4, 0);
  tinygltf::BufferView view;
  view.buffer = 0;
  view.byteOffset = data.size();
  view.byteLength = size;
  view.target = target;
  const auto* begin = static_cast<const unsigned char*>(bytes);
  data.insert(data.end(), begin, begin + size);
  model_.bufferViews.push_back(view);
  return static_cast<int>(model_.bufferViews.size()) - 1;
}

int BufferWriter::add_floats(const torch::Tensor& values, int type, int target) {
  const auto contiguous = values.to(torch::kFloat32).contiguous();
  const int view = add_view(contiguous.data_ptr<float>(), contiguous.numel() * sizeof(float), target);
  tinygltf::Accessor accessor;
  accessor.bufferView = view;
  accessor.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
  accessor.type = type;
  accessor.count = static_cast<size_t>(contiguous.size(0));
  const auto columns = contiguous.reshape({contiguous.size(0), -1}).to(torch::kFloat64);
  const auto lower = std::get<0>(columns.min(0)), upper = std::get<0>(columns.max(0));
  for (int64_t c = 0; c < columns.size(1); ++c) {
    accessor.minValues.push_back(lower[c].item<double>());
    accessor.maxValues.push_back(upper[c].item<double>());
  }
  return add_accessor(accessor);
}

int BufferWriter::add_accessor(const tinygltf::Accessor& accessor) {
  model_.accessors.push_back(accessor);
  return static_cast<int>(model_.accessors.size()) - 1;
}

// Accessor `index` as doubles, `components` per element; checks type and bounds.
std::vector<double> read_accessor(const tinygltf::Model& model, int index, int type, const std::string& path,
                                  const std::string& what) {
  FSKIN_CHECK(index >= 0 && index < static_cast<int>(model.accessors.size()),
              "{}: {} refers to missing accessor {}", path, what, index);
  const auto& accessor = model.accessors[index];
  FSKIN_CHECK(accessor.type == type, "{}: {} has accessor type {}, expected {}", path, what,
              accessor.type, type);
  FSKIN_CHECK(accessor.bufferView >= 0 &&
                  accessor.bufferView < static_cast<int>(model.bufferViews.size()),
              "{}: {} has no buffer view (sparse accessors are not supported)", path, what);
  const auto& view = model.bufferViews[accessor.bufferView];
  FSKIN_CHECK(view.buffer >= 0 && view.buffer < static_cast<int>(model.buffers.size()),
              "{}: {} refers to missing buffer {}", path, what, view.buffer);
  const auto& buffer = model.buffers[view.buffer].data;
  const int components = tinygltf::GetNumComponentsInType(type);
  const int component_size = tinygltf::GetComponentSizeInBytes(accessor.componentType);
  const int stride = accessor.ByteStride(view);
  FSKIN_CHECK(components > 0 && component_size > 0 && stride > 0,
              "{}: {} has an invalid component type {} or stride", path, what,
              accessor.componentType);
  const size_t begin = view.byteOffset + accessor.byteOffset;
  const size_t element = static_cast<size_t>(components) * component_size;
  FSKIN_CHECK(accessor.count == 0 ||
                  (accessor.byteOffset + (accessor.count - 1) * stride + element <=
                       view.byteLength &&
                   view.byteOffset + view.byteLength <= buffer.size()),
              "{}: {} reads past the end of its buffer", path, what);
  std::vector<double> values;
  values.reserve(accessor.count * components);
  for (size_t i = 0; i < accessor.count; ++i) {
    const unsigned char* at = buffer.data() + begin + i * stride;
    for (int c = 0; c < components; ++c, at += component_size) {
      switch (accessor.componentType) {
        case TINYGLTF_COMPONENT_TYPE_FLOAT: {
          float v;
          std::memcpy(&v, at, sizeof v);
          values.push_back(v);
          break;
        }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
          uint32_t v;
          std::memcpy(&v, at, sizeof v);
          values.push_back(v);
          break;
        }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
          uint16_t v;
          std::memcpy(&v, at, sizeof v);
          values.push_back(accessor.normalized ? v / 65535.0 : v);
          break;
        }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
          values.push_back(accessor.normalized ? *at / 255.0 : *at);
          break;
        default:
          fail("{}: {} has unsupported component type {}", path, what, accessor.componentType);
      }
    }
  }
  return values;
}

}  // namespace fskin::gltf

#include "io/gltf_file.h"

#include <torch/torch.h>

#include <algorithm>
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

namespace {

// Images are not needed by any reader (fskin reads meshes, skins and clips):
// keeping them undecoded also keeps stb_image away from hostile textures.
bool keep_image_undecoded(tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*, int,
                          void*) {
  return true;
}

// External buffers: regular files only (a `uri` naming a directory or a
// device is an error naming it, not a read of whatever it yields).
bool read_external_file(std::vector<unsigned char>* out, std::string* err, const std::string& file, void*) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(file, ec)) {
    if (err) *err += "'" + file + "' is not a regular file\n";
    return false;
  }
  try {
    const std::string bytes = read_file(file);
    out->assign(bytes.begin(), bytes.end());
    return true;
  } catch (const std::exception& e) {
    if (err) *err += e.what();
    return false;
  }
}

}  // namespace

tinygltf::Model load(const std::string& path) {
  FSKIN_CHECK(std::filesystem::exists(path), "{}: no such file", path);
  const bool binary = is_binary_path(path);
  FSKIN_CHECK(std::filesystem::is_regular_file(path), "{}: not a regular file", path);
  const std::string bytes = read_file(path);
  FSKIN_CHECK(bytes.size() < (size_t{1} << 32), "{}: {} bytes, beyond what a glTF file may hold (4 GiB)", path,
              bytes.size());
  tinygltf::Model model;
  tinygltf::TinyGLTF gltf;
  gltf.SetImageLoader(keep_image_undecoded, nullptr);
  tinygltf::FsCallbacks callbacks{&tinygltf::FileExists, &tinygltf::ExpandFilePath, &read_external_file,
                                  &tinygltf::WriteWholeFile, nullptr};
  gltf.SetFsCallbacks(callbacks);
  std::string error, warning;
  const auto* data = reinterpret_cast<const unsigned char*>(bytes.data());
  const std::string base_dir = std::filesystem::path(path).parent_path().string();
  bool ok = false;
  try {
    ok = binary ? gltf.LoadBinaryFromMemory(&model, &error, &warning, data, static_cast<unsigned int>(bytes.size()),
                                            base_dir)
                : gltf.LoadASCIIFromString(&model, &error, &warning, bytes.data(),
                                           static_cast<unsigned int>(bytes.size()), base_dir);
  } catch (const std::exception& e) {  // tinygltf's JSON parser and allocations throw on hostile input
    fail("{}: not a readable glTF file: {}", path, e.what());
  }
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

int BufferWriter::add_floats(const torch::Tensor& values, int type, int target, bool bounds) {
  const auto contiguous = values.to(torch::kFloat32).contiguous();
  const int view = add_view(contiguous.data_ptr<float>(), contiguous.numel() * sizeof(float), target);
  tinygltf::Accessor accessor;
  accessor.bufferView = view;
  accessor.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
  accessor.type = type;
  accessor.count = static_cast<size_t>(contiguous.size(0));
  if (!bounds) return add_accessor(accessor);
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

namespace {

// Accessors may hold more values than any character without a file backing
// them (sparse accessors without a buffer view are zeros plus substitutions):
// 2^27 values (1 GiB of doubles) is far beyond a character and far below
// what exhausts a machine.
constexpr size_t kMostAccessorValues = size_t{1} << 27;

// offset + (count - 1) * stride + element <= length, without wrapping around
// (a byteOffset near 2^64 must not pass the check by overflowing).
bool span_fits(size_t offset, size_t count, size_t stride, size_t element, size_t length) {
  if (offset > length) return false;
  if (count == 0) return true;
  size_t last = 0, end = 0;
  if (__builtin_mul_overflow(count - 1, stride, &last)) return false;
  if (__builtin_add_overflow(offset, last, &end)) return false;
  if (__builtin_add_overflow(end, element, &end)) return false;
  return end <= length;
}

// The bytes of buffer view `index`, bounds-checked against its buffer.
std::pair<const unsigned char*, size_t> view_bytes(const tinygltf::Model& model, int index, const std::string& path,
                                                   const std::string& what) {
  FSKIN_CHECK(index >= 0 && index < static_cast<int>(model.bufferViews.size()),
              "{}: {} refers to missing buffer view {}", path, what, index);
  const auto& view = model.bufferViews[index];
  FSKIN_CHECK(view.buffer >= 0 && view.buffer < static_cast<int>(model.buffers.size()),
              "{}: {} refers to missing buffer {}", path, what, view.buffer);
  const auto& buffer = model.buffers[view.buffer].data;
  FSKIN_CHECK(span_fits(view.byteOffset, 1, 0, view.byteLength, buffer.size()),
              "{}: buffer view {} of {} (offset {}, length {}) reaches past the end of its {}-byte buffer", path, index,
              what, view.byteOffset, view.byteLength, buffer.size());
  return {buffer.data() + view.byteOffset, view.byteLength};
}

// One component at `at` as a double; normalised integers map to [0, 1]
// (unsigned) or [-1, 1] (signed), as glTF 2.0 sec. 3.11 defines them.
double read_component(const unsigned char* at, int component_type, bool normalized, const std::string& path,
                      const std::string& what) {
  switch (component_type) {
    case TINYGLTF_COMPONENT_TYPE_FLOAT: {
      float v;
      std::memcpy(&v, at, sizeof v);
      return v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
      uint32_t v;
      std::memcpy(&v, at, sizeof v);
      return v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
      uint16_t v;
      std::memcpy(&v, at, sizeof v);
      return normalized ? v / 65535.0 : v;
    }
    case TINYGLTF_COMPONENT_TYPE_SHORT: {
      int16_t v;
      std::memcpy(&v, at, sizeof v);
      return normalized ? std::max(v / 32767.0, -1.0) : v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
      return normalized ? *at / 255.0 : *at;
    case TINYGLTF_COMPONENT_TYPE_BYTE: {
      const auto v = static_cast<int8_t>(*at);
      return normalized ? std::max(v / 127.0, -1.0) : v;
    }
    default:
      fail("{}: {} has unsupported component type {}", path, what, component_type);
  }
}

}  // namespace

// Accessor `index` as doubles, `components` per element; checks type and
// bounds with overflow-safe arithmetic, and applies sparse substitutions.
std::vector<double> read_accessor(const tinygltf::Model& model, int index, int type, const std::string& path,
                                  const std::string& what) {
  FSKIN_CHECK(index >= 0 && index < static_cast<int>(model.accessors.size()),
              "{}: {} refers to missing accessor {}", path, what, index);
  const auto& accessor = model.accessors[index];
  FSKIN_CHECK(accessor.type == type, "{}: {} has accessor type {}, expected {}", path, what,
              accessor.type, type);
  const int components = tinygltf::GetNumComponentsInType(type);
  const int component_size = tinygltf::GetComponentSizeInBytes(accessor.componentType);
  FSKIN_CHECK(components > 0 && component_size > 0, "{}: {} has an invalid component type {}", path, what,
              accessor.componentType);
  const size_t element = static_cast<size_t>(components) * component_size;
  FSKIN_CHECK(accessor.count <= kMostAccessorValues / components,
              "{}: {} claims {} elements, more than the {} values fskin reads from one accessor", path, what,
              accessor.count, kMostAccessorValues);
  std::vector<double> values;
  if (accessor.bufferView >= 0) {
    const auto [bytes, length] = view_bytes(model, accessor.bufferView, path, what);
    const int stride = accessor.ByteStride(model.bufferViews[accessor.bufferView]);
    FSKIN_CHECK(stride > 0, "{}: {} has an invalid byte stride", path, what);
    // glTF 2.0 sec. 3.6.2.4: an accessor's start is aligned to its component
    // size (misaligned data is another file's bytes read as numbers).
    const size_t start = model.bufferViews[accessor.bufferView].byteOffset + accessor.byteOffset;
    FSKIN_CHECK(accessor.byteOffset % component_size == 0 && start % component_size == 0,
                "{}: {} starts at byte {}, not a multiple of its {}-byte components", path, what, start,
                component_size);
    FSKIN_CHECK(span_fits(accessor.byteOffset, accessor.count, static_cast<size_t>(stride), element, length),
                "{}: {} ({} elements from byte {}) reads past the end of its {}-byte buffer view", path, what,
                accessor.count, accessor.byteOffset, length);
    values.reserve(accessor.count * components);
    for (size_t i = 0; i < accessor.count; ++i) {
      const unsigned char* at = bytes + accessor.byteOffset + i * stride;
      for (int c = 0; c < components; ++c, at += component_size)
        values.push_back(read_component(at, accessor.componentType, accessor.normalized, path, what));
    }
  } else {
    FSKIN_CHECK(accessor.sparse.isSparse, "{}: {} has neither a buffer view nor sparse values", path, what);
    values.assign(accessor.count * components, 0.0);  // glTF: zeros where no buffer view backs it
  }
  if (!accessor.sparse.isSparse) return values;

  // Sparse substitution (glTF 2.0 sec. 3.6.2.3): `count` strictly increasing
  // element indices, then as many elements of the accessor's type.
  const auto& sparse = accessor.sparse;
  FSKIN_CHECK(sparse.count >= 1 && static_cast<size_t>(sparse.count) <= accessor.count,
              "{}: {} has {} sparse values for {} elements", path, what, sparse.count, accessor.count);
  const int index_size = tinygltf::GetComponentSizeInBytes(sparse.indices.componentType);
  FSKIN_CHECK(sparse.indices.componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ||
                  sparse.indices.componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT ||
                  sparse.indices.componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT,
              "{}: {} has sparse indices of component type {} (unsigned byte, short or int expected)", path, what,
              sparse.indices.componentType);
  FSKIN_CHECK(sparse.indices.byteOffset >= 0 && sparse.values.byteOffset >= 0,
              "{}: {} has a negative sparse byte offset", path, what);
  const auto [index_bytes, index_length] = view_bytes(model, sparse.indices.bufferView, path, what + " sparse indices");
  const auto [value_bytes, value_length] = view_bytes(model, sparse.values.bufferView, path, what + " sparse values");
  const auto n = static_cast<size_t>(sparse.count);
  FSKIN_CHECK(span_fits(sparse.indices.byteOffset, n, index_size, index_size, index_length),
              "{}: {}'s {} sparse indices read past the end of their buffer view", path, what, n);
  FSKIN_CHECK(span_fits(sparse.values.byteOffset, n, element, element, value_length),
              "{}: {}'s {} sparse values read past the end of their buffer view", path, what, n);
  double previous = -1;
  for (size_t i = 0; i < n; ++i) {
    const double target = read_component(index_bytes + sparse.indices.byteOffset + i * index_size,
                                         sparse.indices.componentType, false, path, what);
    FSKIN_CHECK(target > previous && target < static_cast<double>(accessor.count),
                "{}: {} sparse index {} is {} (strictly increasing and below {} expected)", path, what, i, target,
                accessor.count);
    previous = target;
    const unsigned char* at = value_bytes + sparse.values.byteOffset + i * element;
    for (int c = 0; c < components; ++c, at += component_size)
      values[static_cast<size_t>(target) * components + c] =
          read_component(at, accessor.componentType, accessor.normalized, path, what);
  }
  return values;
}

}  // namespace fskin::gltf

#include "fskin/io/mesh_io.h"

#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <sstream>

#include "fskin/core/error.h"
#include "fskin/util/atomic_file.h"

#define TINYOBJLOADER_IMPLEMENTATION
#include <tiny_obj_loader.h>

namespace fskin::io {

namespace {

std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
  return ext;
}

Mesh make_mesh(std::vector<float>&& xyz, std::vector<int64_t>&& tris, std::vector<uint8_t>&& rgb,
               const std::string& path) {
  Mesh mesh;
  const int64_t v = static_cast<int64_t>(xyz.size() / 3);
  mesh.vertices = torch::from_blob(xyz.data(), {v, 3}, torch::kFloat32).clone();
  mesh.faces = torch::from_blob(tris.data(), {static_cast<int64_t>(tris.size() / 3), 3},
                                torch::kInt64)
                   .clone();
  if (!rgb.empty()) mesh.colors = torch::from_blob(rgb.data(), {v, 3}, torch::kUInt8).clone();
  mesh.validate(path);
  return mesh;
}

// ----------------------------------------------------------------------------
// PLY. Hand-written: Debian packages no PLY library (tinyply / happly are not
// packaged, assimp is far heavier than a header parser and a byte cursor).

enum class PlyFormat { kAscii, kBinaryLittle, kBinaryBig };

struct PlyProperty {
  std::string name, type, list_count_type;  // list_count_type empty for scalars
};

struct PlyElement {
  std::string name;
  int64_t count = 0;
  std::vector<PlyProperty> properties;
};

size_t ply_type_size(const std::string& type, const std::string& path) {
  static const std::pair<const char*, size_t> kSizes[] = {
      {"char", 1},  {"uchar", 1},  {"int8", 1},  {"uint8", 1},   {"short", 2},  {"ushort", 2},
      {"int16", 2}, {"uint16", 2}, {"int", 4},   {"uint", 4},    {"int32", 4},  {"uint32", 4},
      {"float", 4}, {"float32", 4}, {"double", 8}, {"float64", 8}};
  for (const auto& [name, size] : kSizes)
    if (type == name) return size;
  fail("{}: unknown PLY property type '{}'", path, type);
}

// Reads scalars from the body, ascii or binary, with bounds checks.
class PlyCursor {
 public:
  PlyCursor(const std::string& bytes, size_t offset, PlyFormat format, const std::string& path)
      : bytes_(bytes), pos_(offset), format_(format), path_(path) {}

  double read(const std::string& type) {
    if (format_ == PlyFormat::kAscii) return read_ascii();
    const size_t size = ply_type_size(type, path_);
    FSKIN_CHECK(pos_ + size <= bytes_.size(), "{}: truncated PLY data (binary body ends early)",
                path_);
    unsigned char raw[8];
    std::memcpy(raw, bytes_.data() + pos_, size);
    pos_ += size;
    if (format_ == PlyFormat::kBinaryBig) std::reverse(raw, raw + size);
    const std::string& t = type;
    if (t == "char" || t == "int8") return static_cast<int8_t>(raw[0]);
    if (t == "uchar" || t == "uint8") return raw[0];
    if (t == "short" || t == "int16") return load<int16_t>(raw);
    if (t == "ushort" || t == "uint16") return load<uint16_t>(raw);
    if (t == "int" || t == "int32") return load<int32_t>(raw);
    if (t == "uint" || t == "uint32") return load<uint32_t>(raw);
    if (t == "float" || t == "float32") return load<float>(raw);
    return load<double>(raw);
  }

 private:
  template <typename T>
  static double load(const unsigned char* raw) {
    T value;
    std::memcpy(&value, raw, sizeof(T));
    return static_cast<double>(value);
  }
  double read_ascii() {
    while (pos_ < bytes_.size() && std::isspace(static_cast<unsigned char>(bytes_[pos_]))) ++pos_;
    FSKIN_CHECK(pos_ < bytes_.size(), "{}: truncated PLY data (ascii body ends early)", path_);
    const char* start = bytes_.c_str() + pos_;
    char* end = nullptr;
    const double value = std::strtod(start, &end);
    FSKIN_CHECK(end != start, "{}: bad number in ascii PLY body near byte {}", path_, pos_);
    pos_ += static_cast<size_t>(end - start);
    return value;
  }
  const std::string& bytes_;
  size_t pos_;
  PlyFormat format_;
  const std::string& path_;
};

}  // namespace

Mesh read_ply(const std::string& path) {
  const std::string bytes = read_file(path);
  const size_t header_end = bytes.find("end_header");
  FSKIN_CHECK(bytes.rfind("ply", 0) == 0 && header_end != std::string::npos,
              "{}: not a PLY file (missing 'ply' magic or 'end_header')", path);
  std::istringstream header(bytes.substr(0, header_end));
  PlyFormat format = PlyFormat::kAscii;
  bool has_format = false;
  std::vector<PlyElement> elements;
  std::string line;
  while (std::getline(header, line)) {
    std::istringstream words(line);
    std::string keyword;
    words >> keyword;
    if (keyword == "format") {
      std::string f;
      words >> f;
      has_format = true;
      if (f == "ascii") format = PlyFormat::kAscii;
      else if (f == "binary_little_endian") format = PlyFormat::kBinaryLittle;
      else if (f == "binary_big_endian") format = PlyFormat::kBinaryBig;
      else fail("{}: unknown PLY format '{}'", path, f);
    } else if (keyword == "element") {
      PlyElement e;
      words >> e.name >> e.count;
      FSKIN_CHECK(!words.fail() && e.count >= 0, "{}: bad PLY element line '{}'", path, line);
      elements.push_back(e);
    } else if (keyword == "property") {
      FSKIN_CHECK(!elements.empty(), "{}: PLY property before any element", path);
      PlyProperty p;
      std::string type;
      words >> type;
      if (type == "list") words >> p.list_count_type >> p.type >> p.name;
      else {
        p.type = type;
        words >> p.name;
      }
      FSKIN_CHECK(!words.fail(), "{}: bad PLY property line '{}'", path, line);
      ply_type_size(p.type, path);
      if (!p.list_count_type.empty()) ply_type_size(p.list_count_type, path);
      elements.back().properties.push_back(p);
    }
  }
  FSKIN_CHECK(has_format, "{}: PLY header has no format line", path);
  size_t body = bytes.find('\n', header_end);
  FSKIN_CHECK(body != std::string::npos, "{}: truncated PLY header", path);
  PlyCursor cursor(bytes, body + 1, format, path);

  std::vector<float> xyz;
  std::vector<uint8_t> rgb;
  std::vector<int64_t> tris;
  bool has_vertices = false;
  for (const auto& e : elements) {
    const bool is_vertex = e.name == "vertex", is_face = e.name == "face";
    int ix = -1, iy = -1, iz = -1, ir = -1, ig = -1, ib = -1, iface = -1;
    for (size_t k = 0; k < e.properties.size(); ++k) {
      const auto& n = e.properties[k].name;
      if (n == "x") ix = k;
      else if (n == "y") iy = k;
      else if (n == "z") iz = k;
      else if (n == "red") ir = k;
      else if (n == "green") ig = k;
      else if (n == "blue") ib = k;
      else if (n == "vertex_indices" || n == "vertex_index") iface = k;
    }
    if (is_vertex) {
      FSKIN_CHECK(ix >= 0 && iy >= 0 && iz >= 0, "{}: PLY vertex element lacks x, y or z", path);
      has_vertices = true;
      xyz.reserve(3 * e.count);
    }
    if (is_face) FSKIN_CHECK(iface >= 0, "{}: PLY face element lacks vertex_indices", path);
    const bool colors = is_vertex && ir >= 0 && ig >= 0 && ib >= 0;
    std::vector<double> values(e.properties.size());
    std::vector<int64_t> polygon;
    for (int64_t i = 0; i < e.count; ++i) {
      for (size_t k = 0; k < e.properties.size(); ++k) {
        const auto& p = e.properties[k];
        if (p.list_count_type.empty()) {
          values[k] = cursor.read(p.type);
          continue;
        }
        const double n = cursor.read(p.list_count_type);
        FSKIN_CHECK(n >= 0 && n < 1e6, "{}: bad PLY list length {}", path, n);
        polygon.clear();
        for (int64_t c = 0; c < static_cast<int64_t>(n); ++c)
          polygon.push_back(static_cast<int64_t>(cursor.read(p.type)));
        if (is_face && static_cast<int>(k) == iface) {
          FSKIN_CHECK(polygon.size() >= 3, "{}: face {} has {} vertices", path, i, polygon.size());
          for (size_t c = 1; c + 1 < polygon.size(); ++c)  // fan triangulation
            tris.insert(tris.end(), {polygon[0], polygon[c], polygon[c + 1]});
        }
      }
      if (is_vertex) {
        xyz.insert(xyz.end(), {static_cast<float>(values[ix]), static_cast<float>(values[iy]),
                               static_cast<float>(values[iz])});
        if (colors)
          rgb.insert(rgb.end(), {static_cast<uint8_t>(values[ir]), static_cast<uint8_t>(values[ig]),
                                 static_cast<uint8_t>(values[ib])});
      }
    }
  }
  FSKIN_CHECK(has_vertices, "{}: PLY file has no vertex element", path);
  return make_mesh(std::move(xyz), std::move(tris), std::move(rgb), path);
}

void write_ply(const std::string& path, const Mesh& mesh) {
  mesh.validate(path);
  const auto v = mesh.vertices.contiguous();
  const auto f = mesh.faces.to(torch::kInt32).contiguous();
  const bool colors = mesh.colors.defined();
  const auto c = colors ? mesh.colors.to(torch::kUInt8).contiguous() : torch::Tensor();
  std::string out = "ply\nformat binary_little_endian 1.0\ncomment written by fskin\n";
  out += "element vertex " + std::to_string(mesh.num_vertices()) + "\n";
  out += "property float x\nproperty float y\nproperty float z\n";
  if (colors) out += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  out += "element face " + std::to_string(mesh.num_faces()) + "\n";
  out += "property list uchar int vertex_indices\nend_header\n";
  const float* vp = v.data_ptr<float>();
  const uint8_t* cp = colors ? c.data_ptr<uint8_t>() : nullptr;
  for (int64_t i = 0; i < mesh.num_vertices(); ++i) {
    out.append(reinterpret_cast<const char*>(vp + 3 * i), 12);
    if (colors) out.append(reinterpret_cast<const char*>(cp + 3 * i), 3);
  }
  const int32_t* fp = f.data_ptr<int32_t>();
  for (int64_t i = 0; i < mesh.num_faces(); ++i) {
    out.push_back(3);
    out.append(reinterpret_cast<const char*>(fp + 3 * i), 12);
  }
  write_file_atomically(path, out);
}

// ----------------------------------------------------------------------------
// OBJ: read with tinyobjloader (Debian libtinyobjloader-dev), written by hand
// (a few lines of text).

Mesh read_obj(const std::string& path) {
  FSKIN_CHECK(std::filesystem::exists(path), "{}: no such file", path);
  tinyobj::ObjReaderConfig config;
  config.triangulate = true;
  config.vertex_color = true;
  config.mtl_search_path = "";
  tinyobj::ObjReader reader;
  FSKIN_CHECK(reader.ParseFromFile(path, config), "{}: cannot parse OBJ: {}", path,
              reader.Error());
  const auto& attrib = reader.GetAttrib();
  std::vector<float> xyz(attrib.vertices.begin(), attrib.vertices.end());
  std::vector<int64_t> tris;
  for (const auto& shape : reader.GetShapes()) {
    size_t offset = 0;
    for (const auto count : shape.mesh.num_face_vertices) {
      FSKIN_CHECK(count == 3, "{}: face with {} vertices after triangulation", path, count);
      for (size_t k = 0; k < 3; ++k) tris.push_back(shape.mesh.indices[offset + k].vertex_index);
      offset += count;
    }
  }
  std::vector<uint8_t> rgb;
  // tinyobjloader fills colours with 1.0 when the file has none; keep only real ones.
  const bool has_colors = std::any_of(attrib.colors.begin(), attrib.colors.end(),
                                      [](float x) { return x != 1.0f; });
  if (has_colors && attrib.colors.size() == attrib.vertices.size())
    for (float x : attrib.colors)
      rgb.push_back(static_cast<uint8_t>(std::lround(std::clamp(x, 0.0f, 1.0f) * 255.0f)));
  return make_mesh(std::move(xyz), std::move(tris), std::move(rgb), path);
}

void write_obj(const std::string& path, const Mesh& mesh) {
  mesh.validate(path);
  const auto v = mesh.vertices.contiguous();
  const auto f = mesh.faces.contiguous();
  const bool colors = mesh.colors.defined();
  const auto c = colors ? mesh.colors.to(torch::kUInt8).contiguous() : torch::Tensor();
  write_file_atomically(path, [&](std::ostream& out) {
    out << "# written by fskin\n";
    const float* vp = v.data_ptr<float>();
    char buffer[160];
    for (int64_t i = 0; i < mesh.num_vertices(); ++i) {
      int n = std::snprintf(buffer, sizeof(buffer), "v %.7g %.7g %.7g", vp[3 * i], vp[3 * i + 1],
                            vp[3 * i + 2]);
      if (colors) {
        const uint8_t* cp = c.data_ptr<uint8_t>() + 3 * i;
        n += std::snprintf(buffer + n, sizeof(buffer) - n, " %.6g %.6g %.6g", cp[0] / 255.0,
                           cp[1] / 255.0, cp[2] / 255.0);
      }
      out << buffer << '\n';
    }
    const int64_t* fp = f.data_ptr<int64_t>();
    for (int64_t i = 0; i < mesh.num_faces(); ++i)
      out << "f " << fp[3 * i] + 1 << ' ' << fp[3 * i + 1] + 1 << ' ' << fp[3 * i + 2] + 1 << '\n';
  });
}

Mesh read_mesh(const std::string& path) {
  const std::string ext = lower_extension(path);
  if (ext == ".ply") return read_ply(path);
  if (ext == ".obj") return read_obj(path);
  fail("{}: unsupported mesh format '{}' (use .ply or .obj)", path, ext);
}

void write_mesh(const std::string& path, const Mesh& mesh) {
  const std::string ext = lower_extension(path);
  if (ext == ".ply") return write_ply(path, mesh);
  if (ext == ".obj") return write_obj(path, mesh);
  fail("{}: unsupported mesh format '{}' (use .ply or .obj)", path, ext);
}

}  // namespace fskin::io

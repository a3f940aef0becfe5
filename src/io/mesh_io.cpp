#include "fskin/io/mesh_io.h"

#include <fmt/format.h>
#include <torch/torch.h>
// tinyobjloader is compiled here (its single-header mode) rather than linked, so the
// build needs no find_package for it and the binary no extra shared library.
#define TINYOBJLOADER_IMPLEMENTATION
#include <tiny_obj_loader.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <sstream>

#include "fskin/core/error.h"
#include "fskin/util/atomic_file.h"

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
              "fskin's .ply byte handling assumes a little-endian host");

namespace fskin::io {
namespace {

// Polygon faces as a flat index list plus per-face corner counts, fan-triangulated
// (v0, vk, vk+1) into the [F, 3] int64 faces of a Mesh. Fans keep the polygon's winding.
torch::Tensor fan_triangulate(const std::vector<int64_t>& corners,
                              const std::vector<int64_t>& counts, const std::string& path) {
  std::vector<int64_t> triangles;
  size_t start = 0;
  for (size_t f = 0; f < counts.size(); ++f) {
    const int64_t n = counts[f];
    FSKIN_CHECK(n >= 3, "{}: face {} has {} vertices; a face needs at least 3", path, f, n);
    for (int64_t k = 1; k + 1 < n; ++k) {
      triangles.insert(triangles.end(),
                       {corners[start], corners[start + k], corners[start + k + 1]});
    }
    start += static_cast<size_t>(n);
  }
  const auto count = static_cast<int64_t>(triangles.size() / 3);
  return torch::from_blob(triangles.data(), {count, 3}, torch::kInt64).clone();
}

std::string lowercase_extension(const std::string& path) {
  std::string extension = std::filesystem::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return extension;
}

// ---------------------------------------------------------------------------
// PLY. No Debian package provides a C++ PLY reader (happly, tinyply and rply are not
// packaged), so the format is parsed here: a text header naming elements and their
// typed properties, then the elements in order, as text or binary in either byte order.
// ---------------------------------------------------------------------------

enum class PlyFormat { kAscii, kBinaryLittle, kBinaryBig };

enum class PlyType { kInt8, kUInt8, kInt16, kUInt16, kInt32, kUInt32, kFloat32, kFloat64 };

struct PlyProperty {
  std::string name;
  PlyType type;
  bool is_list = false;
  PlyType count_type = PlyType::kUInt8;
};

struct PlyElement {
  std::string name;
  int64_t count = 0;
  std::vector<PlyProperty> properties;
};

PlyType parse_ply_type(const std::string& name, const std::string& path) {
  static const std::pair<const char*, PlyType> kTypes[] = {
      {"char", PlyType::kInt8},     {"int8", PlyType::kInt8},       {"uchar", PlyType::kUInt8},
      {"uint8", PlyType::kUInt8},   {"short", PlyType::kInt16},     {"int16", PlyType::kInt16},
      {"ushort", PlyType::kUInt16}, {"uint16", PlyType::kUInt16},   {"int", PlyType::kInt32},
      {"int32", PlyType::kInt32},   {"uint", PlyType::kUInt32},     {"uint32", PlyType::kUInt32},
      {"float", PlyType::kFloat32}, {"float32", PlyType::kFloat32}, {"double", PlyType::kFloat64},
      {"float64", PlyType::kFloat64}};
  for (const auto& [text, type] : kTypes) {
    if (name == text) return type;
  }
  fail("{}: bad PLY header: unknown property type '{}'", path, name);
}

size_t ply_type_size(PlyType type) {
  switch (type) {
    case PlyType::kInt8: case PlyType::kUInt8: return 1;
    case PlyType::kInt16: case PlyType::kUInt16: return 2;
    case PlyType::kInt32: case PlyType::kUInt32: case PlyType::kFloat32: return 4;
    case PlyType::kFloat64: return 8;
  }
  return 0;
}

bool is_float_type(PlyType type) { return type == PlyType::kFloat32 || type == PlyType::kFloat64; }

struct PlyHeader {
  PlyFormat format = PlyFormat::kAscii;
  std::vector<PlyElement> elements;
  size_t body_offset = 0;
};

PlyHeader parse_ply_header(const std::string& bytes, const std::string& path) {
  FSKIN_CHECK(bytes.compare(0, 3, "ply") == 0 && bytes.size() > 3 &&
                  (bytes[3] == '\n' || bytes[3] == '\r'),
              "{}: not a PLY file (first line is not 'ply')", path);
  const size_t end = bytes.find("\nend_header");
  FSKIN_CHECK(end != std::string::npos, "{}: bad PLY header: no 'end_header'", path);
  const size_t body = bytes.find('\n', end + 1);
  FSKIN_CHECK(body != std::string::npos, "{}: bad PLY header: no newline after 'end_header'",
              path);
  PlyHeader header;
  header.body_offset = body + 1;
  std::istringstream lines(bytes.substr(0, end));
  std::string line;
  bool have_format = false;
  std::getline(lines, line);  // "ply"
  while (std::getline(lines, line)) {
    std::istringstream words(line);
    std::string keyword;
    if (!(words >> keyword) || keyword == "comment" || keyword == "obj_info") continue;
    if (keyword == "format") {
      std::string format, version;
      words >> format >> version;
      if (format == "ascii") {
        header.format = PlyFormat::kAscii;
      } else if (format == "binary_little_endian") {
        header.format = PlyFormat::kBinaryLittle;
      } else if (format == "binary_big_endian") {
        header.format = PlyFormat::kBinaryBig;
      } else {
        fail("{}: bad PLY header: unknown format '{}'", path, format);
      }
      have_format = true;
    } else if (keyword == "element") {
      PlyElement element;
      FSKIN_CHECK(words >> element.name >> element.count && element.count >= 0,
                  "{}: bad PLY header line '{}'", path, line);
      header.elements.push_back(element);
    } else if (keyword == "property") {
      FSKIN_CHECK(!header.elements.empty(), "{}: bad PLY header: property before any element",
                  path);
      PlyProperty property;
      std::string type;
      FSKIN_CHECK(words >> type, "{}: bad PLY header line '{}'", path, line);
      if (type == "list") {
        std::string count_type, item_type;
        FSKIN_CHECK(words >> count_type >> item_type, "{}: bad PLY header line '{}'", path, line);
        property.is_list = true;
        property.count_type = parse_ply_type(count_type, path);
        FSKIN_CHECK(!is_float_type(property.count_type),
                    "{}: bad PLY header: list count type '{}' is not an integer", path,
                    count_type);
        property.type = parse_ply_type(item_type, path);
      } else {
        property.type = parse_ply_type(type, path);
      }
      FSKIN_CHECK(words >> property.name, "{}: bad PLY header line '{}'", path, line);
      header.elements.back().properties.push_back(property);
    } else {
      fail("{}: bad PLY header: unknown keyword '{}'", path, keyword);
    }
  }
  FSKIN_CHECK(have_format, "{}: bad PLY header: no 'format' line", path);
  return header;
}

// Reads scalar values from the PLY body, as text tokens or binary in either byte order.
class PlyBodyReader {
 public:
  PlyBodyReader(const std::string& bytes, size_t offset, PlyFormat format,
                const std::string& path)
      : bytes_(bytes), pos_(offset), format_(format), path_(path) {}

  // `where` is only evaluated to build the error message.
  template <typename Where>
  double read(PlyType type, const Where& where) {
    return format_ == PlyFormat::kAscii ? read_text(where) : read_binary(type, where);
  }

 private:
  template <typename Where>
  double read_text(const Where& where) {
    while (pos_ < bytes_.size() && std::isspace(static_cast<unsigned char>(bytes_[pos_]))) ++pos_;
    if (pos_ >= bytes_.size()) fail("{}: truncated PLY data at {}", path_, where());
    const char* start = bytes_.c_str() + pos_;
    char* stop = nullptr;
    const double value = std::strtod(start, &stop);
    if (stop == start) {
      fail("{}: bad PLY number '{}' at {}", path_,
           bytes_.substr(pos_, std::min<size_t>(20, bytes_.find_first_of(" \t\r\n", pos_) - pos_)),
           where());
    }
    pos_ += static_cast<size_t>(stop - start);
    return value;
  }

  template <typename Where>
  double read_binary(PlyType type, const Where& where) {
    const size_t size = ply_type_size(type);
    if (pos_ + size > bytes_.size()) {
      fail("{}: truncated PLY data at {} (file ends after {} bytes)", path_, where(),
           bytes_.size());
    }
    unsigned char raw[8];
    std::memcpy(raw, bytes_.data() + pos_, size);
    if (format_ == PlyFormat::kBinaryBig) std::reverse(raw, raw + size);
    pos_ += size;
    switch (type) {
      case PlyType::kInt8: return as<int8_t>(raw);
      case PlyType::kUInt8: return as<uint8_t>(raw);
      case PlyType::kInt16: return as<int16_t>(raw);
      case PlyType::kUInt16: return as<uint16_t>(raw);
      case PlyType::kInt32: return as<int32_t>(raw);
      case PlyType::kUInt32: return as<uint32_t>(raw);
      case PlyType::kFloat32: return as<float>(raw);
      case PlyType::kFloat64: return as<double>(raw);
    }
    return 0.0;
  }

  template <typename T>
  static double as(const unsigned char* raw) {
    T value;
    std::memcpy(&value, raw, sizeof(T));
    return static_cast<double>(value);
  }

  const std::string& bytes_;
  size_t pos_;
  PlyFormat format_;
  const std::string& path_;
};

// A colour channel as uint8: integer channels are 0..255, float channels 0..1.
uint8_t color_channel(double value, PlyType type) {
  const double scaled = is_float_type(type) ? value * 255.0 : value;
  return static_cast<uint8_t>(std::clamp(std::round(scaled), 0.0, 255.0));
}

void write_binary(std::string& out, const void* data, size_t size) {
  out.append(static_cast<const char*>(data), size);
}

}  // namespace

Mesh read_ply(const std::string& path) {
  const std::string bytes = read_file(path);
  const PlyHeader header = parse_ply_header(bytes, path);
  PlyBodyReader reader(bytes, header.body_offset, header.format, path);

  std::vector<float> vertices;
  std::vector<uint8_t> colors;
  std::vector<int64_t> corners, counts;
  bool have_vertices = false, have_colors = false;
  for (const PlyElement& element : header.elements) {
    const bool is_vertex = element.name == "vertex", is_face = element.name == "face";
    // Which property feeds which output: x,y,z -> 0..2, red,green,blue -> 3..5.
    std::vector<int> role(element.properties.size(), -1);
    int face_list = -1;
    // Every instance of an element with properties takes at least one byte; checked
    // before reserving memory for what a damaged header may announce.
    FSKIN_CHECK(element.properties.empty() ||
                    static_cast<uint64_t>(element.count) <= bytes.size() - header.body_offset,
                "{}: truncated PLY data: header announces {} '{}' elements, the body has {} bytes",
                path, element.count, element.name, bytes.size() - header.body_offset);
    if (is_vertex) {
      FSKIN_CHECK(!have_vertices, "{}: bad PLY header: two 'vertex' elements", path);
      have_vertices = true;
      const char* names[] = {"x", "y", "z", "red", "green", "blue"};
      for (int r = 0; r < 6; ++r) {
        for (size_t p = 0; p < element.properties.size(); ++p) {
          if (element.properties[p].name == names[r] && !element.properties[p].is_list) role[p] = r;
        }
        const bool found = std::count(role.begin(), role.end(), r) > 0;
        FSKIN_CHECK(found || r >= 3, "{}: bad PLY header: vertex has no '{}' property", path,
                    names[r]);
        if (r == 3) have_colors = found;
        if (r > 3) FSKIN_CHECK(found == have_colors, "{}: PLY colours need red, green and blue", path);
      }
      vertices.resize(static_cast<size_t>(element.count) * 3);
      if (have_colors) colors.resize(static_cast<size_t>(element.count) * 3);
    }
    if (is_face) {
      for (size_t p = 0; p < element.properties.size(); ++p) {
        const auto& name = element.properties[p].name;
        if (element.properties[p].is_list && (name == "vertex_indices" || name == "vertex_index")) {
          face_list = static_cast<int>(p);
        }
      }
      FSKIN_CHECK(face_list >= 0,
                  "{}: bad PLY header: face has no 'vertex_indices' list property", path);
      FSKIN_CHECK(!is_float_type(element.properties[face_list].type),
                  "{}: bad PLY header: face indices must be integers", path);
      counts.reserve(static_cast<size_t>(element.count));
      corners.reserve(static_cast<size_t>(element.count) * 3);
    }
    for (int64_t i = 0; i < element.count; ++i) {
      for (size_t p = 0; p < element.properties.size(); ++p) {
        const PlyProperty& property = element.properties[p];
        auto where = [&] {
          return fmt::format("element '{}' #{} property '{}'", element.name, i, property.name);
        };
        if (!property.is_list) {
          const double value = reader.read(property.type, where);
          if (role[p] >= 0 && role[p] < 3) {
            // Out-of-range doubles become inf (converting them is undefined behaviour), which
            // Mesh::validate then rejects like NaN.
            vertices[static_cast<size_t>(i) * 3 + role[p]] =
                std::isfinite(value) && std::abs(value) > std::numeric_limits<float>::max()
                    ? (value > 0 ? 1.f : -1.f) * std::numeric_limits<float>::infinity()
                    : static_cast<float>(value);
          } else if (role[p] >= 3) {
            colors[static_cast<size_t>(i) * 3 + role[p] - 3] = color_channel(value, property.type);
          }
          continue;
        }
        const double count = reader.read(property.count_type, where);
        FSKIN_CHECK(count >= 0 && count == std::floor(count), "{}: bad list length {} at {}",
                    path, count, where());
        for (int64_t k = 0; k < static_cast<int64_t>(count); ++k) {
          const double value = reader.read(property.type, where);
          if (static_cast<int>(p) == face_list) corners.push_back(static_cast<int64_t>(value));
        }
        if (static_cast<int>(p) == face_list) counts.push_back(static_cast<int64_t>(count));
      }
    }
  }
  FSKIN_CHECK(have_vertices, "{}: PLY file has no 'vertex' element", path);
  Mesh mesh;
  const auto vertex_count = static_cast<int64_t>(vertices.size() / 3);
  mesh.vertices = torch::from_blob(vertices.data(), {vertex_count, 3}, torch::kFloat32).clone();
  mesh.faces = fan_triangulate(corners, counts, path);
  if (have_colors) {
    mesh.colors = torch::from_blob(colors.data(), {vertex_count, 3}, torch::kUInt8).clone();
  }
  mesh.validate(path);
  return mesh;
}

void write_ply(const std::string& path, const Mesh& mesh) {
  mesh.validate(path);
  FSKIN_CHECK(mesh.num_vertices() <= std::numeric_limits<int32_t>::max(),
              "{}: too many vertices for 32-bit PLY indices", path);
  const bool with_colors = mesh.colors.defined();
  std::string out = fmt::format(
      "ply\nformat binary_little_endian 1.0\ncomment written by fskin\n"
      "element vertex {}\nproperty float x\nproperty float y\nproperty float z\n{}"
      "element face {}\nproperty list uchar int vertex_indices\nend_header\n",
      mesh.num_vertices(),
      with_colors ? "property uchar red\nproperty uchar green\nproperty uchar blue\n" : "",
      mesh.num_faces());
  const torch::Tensor vertices = mesh.vertices.contiguous();
  const torch::Tensor faces = mesh.faces.to(torch::kInt32).contiguous();
  torch::Tensor colors;
  if (with_colors) colors = mesh.colors.to(torch::kUInt8).contiguous();
  const float* v = vertices.data_ptr<float>();
  const uint8_t* c = with_colors ? colors.data_ptr<uint8_t>() : nullptr;
  for (int64_t i = 0; i < mesh.num_vertices(); ++i) {
    write_binary(out, v + 3 * i, 3 * sizeof(float));
    if (c) write_binary(out, c + 3 * i, 3);
  }
  const int32_t* f = faces.data_ptr<int32_t>();
  for (int64_t i = 0; i < mesh.num_faces(); ++i) {
    out += static_cast<char>(3);
    write_binary(out, f + 3 * i, 3 * sizeof(int32_t));
  }
  write_file_atomically(path, out);
}

Mesh read_obj(const std::string& path) {
  const std::string text = read_file(path);
  // One pass over the 'v' lines first: tinyobjloader silently reads "nan" and "inf" as 0,
  // and fills absent vertex colours with 1.0, so neither can be told apart afterwards.
  std::istringstream lines(text);
  std::string line;
  bool every_vertex_colored = true;
  int64_t vertex_lines = 0;
  for (int64_t number = 1; std::getline(lines, line); ++number) {
    std::istringstream words(line.substr(0, line.find('#')));
    std::string word;
    if (!(words >> word) || word != "v") continue;
    int values = 0;
    while (words >> word) {
      ++values;
      std::transform(word.begin(), word.end(), word.begin(),
                     [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
      const size_t sign = word[0] == '-' || word[0] == '+' ? 1 : 0;
      FSKIN_CHECK(word.compare(sign, 3, "nan") != 0 && word.compare(sign, 3, "inf") != 0,
                  "{}: line {}: non-finite vertex coordinate: {}", path, number, line);
    }
    ++vertex_lines;
    every_vertex_colored = every_vertex_colored && values == 6;  // "v x y z r g b"
  }
  tinyobj::ObjReaderConfig config;
  // Triangulated here instead of by tinyobjloader, which drops quads with out-of-range
  // indices with only a warning; Mesh::validate then reports them.
  config.triangulate = false;
  config.vertex_color = true;
  tinyobj::ObjReader reader;
  // ParseFromString ignores 'mtllib': materials are not part of a fskin Mesh.
  FSKIN_CHECK(reader.ParseFromString(text, "", config), "{}: cannot parse OBJ: {}", path,
              reader.Error());
  const auto& attrib = reader.GetAttrib();
  std::vector<int64_t> corners, counts;
  for (const auto& shape : reader.GetShapes()) {
    for (const auto& index : shape.mesh.indices) corners.push_back(index.vertex_index);
    for (const auto n : shape.mesh.num_face_vertices) counts.push_back(n);
  }
  Mesh mesh;
  std::vector<float> vertices(attrib.vertices.begin(), attrib.vertices.end());
  const auto vertex_count = static_cast<int64_t>(vertices.size() / 3);
  mesh.vertices = torch::from_blob(vertices.data(), {vertex_count, 3}, torch::kFloat32).clone();
  mesh.faces = fan_triangulate(corners, counts, path);
  if (vertex_lines > 0 && every_vertex_colored && attrib.colors.size() == attrib.vertices.size()) {
    std::vector<uint8_t> colors;
    for (float channel : attrib.colors) colors.push_back(color_channel(channel, PlyType::kFloat32));
    mesh.colors = torch::from_blob(colors.data(), {vertex_count, 3}, torch::kUInt8).clone();
  }
  mesh.validate(path);
  return mesh;
}

void write_obj(const std::string& path, const Mesh& mesh) {
  mesh.validate(path);
  const torch::Tensor vertices = mesh.vertices.contiguous();
  const torch::Tensor faces = mesh.faces.contiguous();
  torch::Tensor colors;
  if (mesh.colors.defined()) colors = mesh.colors.to(torch::kUInt8).contiguous();
  const float* v = vertices.data_ptr<float>();
  const int64_t* f = faces.data_ptr<int64_t>();
  const uint8_t* c = colors.defined() ? colors.data_ptr<uint8_t>() : nullptr;
  fmt::memory_buffer out;
  auto text = std::back_inserter(out);
  fmt::format_to(text, "# written by fskin\n");
  // fmt prints the shortest text that reads back as the same float, so the round trip is
  // exact. Colours follow the coordinates as 0..1 values (the MeshLab convention).
  for (int64_t i = 0; i < mesh.num_vertices(); ++i) {
    fmt::format_to(text, "v {} {} {}", v[3 * i], v[3 * i + 1], v[3 * i + 2]);
    if (c) {
      fmt::format_to(text, " {} {} {}", c[3 * i] / 255.f, c[3 * i + 1] / 255.f, c[3 * i + 2] / 255.f);
    }
    fmt::format_to(text, "\n");
  }
  for (int64_t i = 0; i < mesh.num_faces(); ++i) {
    fmt::format_to(text, "f {} {} {}\n", f[3 * i] + 1, f[3 * i + 1] + 1, f[3 * i + 2] + 1);
  }
  write_file_atomically(path, fmt::to_string(out));
}

Mesh read_mesh(const std::string& path) {
  const std::string extension = lowercase_extension(path);
  if (extension == ".ply") return read_ply(path);
  if (extension == ".obj") return read_obj(path);
  fail("{}: unsupported mesh format '{}' (expected .ply or .obj)", path, extension);
}

void write_mesh(const std::string& path, const Mesh& mesh) {
  const std::string extension = lowercase_extension(path);
  if (extension == ".ply") return write_ply(path, mesh);
  if (extension == ".obj") return write_obj(path, mesh);
  fail("{}: unsupported mesh format '{}' (expected .ply or .obj)", path, extension);
}

}  // namespace fskin::io

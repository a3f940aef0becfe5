#include "fskin/io/npz.h"

#include <fmt/ranges.h>
#include <zip.h>
#include <zlib.h>

#include <algorithm>
#include <cctype>
#include <cstring>
#include <filesystem>
#include <limits>
#include <mutex>
#include <optional>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/util/atomic_file.h"
#include "io/npy_format.h"

// No Debian package reads .npy from C++ (cnpy is not packaged), so arrays are decoded
// here (header grammar in npy_format.cpp); the zip container is handled by libzip.

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
              "fskin's .npy/.ply byte handling assumes a little-endian host");

namespace fskin::io {
namespace {

// How the bytes of one element are stored and what they become in memory.
struct Dtype {
  enum class Kind { kNumber, kUnsigned32, kUnicode, kBytes } kind;
  torch::ScalarType scalar;  // for kNumber: the tensor type holding the raw bytes
  size_t item_size;
};

std::optional<Dtype> parse_dtype(const std::string& descr) {
  if (descr.size() < 3) return std::nullopt;
  const char order = descr[0], code = descr[1];
  size_t size = 0;
  try {
    size_t used = 0;
    size = std::stoul(descr.substr(2), &used);
    if (used != descr.size() - 2) return std::nullopt;
  } catch (const std::exception&) {
    return std::nullopt;
  }
  if (size == 0 || size > (size_t{1} << 24)) return std::nullopt;
  const bool little = order == '<', none = order == '|';
  // '<U n': n UTF-32LE code units per string.
  if (code == 'U' && little) return Dtype{Dtype::Kind::kUnicode, torch::kUInt8, 4 * size};
  if (code == 'S' && none) return Dtype{Dtype::Kind::kBytes, torch::kUInt8, size};
  // One-byte types have no byte order: numpy writes '|', other writers sometimes '<'.
  if (size == 1 && (little || none)) {
    if (code == 'f') return std::nullopt;
    if (code == 'i') return Dtype{Dtype::Kind::kNumber, torch::kInt8, 1};
    if (code == 'u') return Dtype{Dtype::Kind::kNumber, torch::kUInt8, 1};
    if (code == 'b') return Dtype{Dtype::Kind::kNumber, torch::kBool, 1};
    return std::nullopt;
  }
  if (!little) return std::nullopt;
  if (code == 'f' && size == 4) return Dtype{Dtype::Kind::kNumber, torch::kFloat32, 4};
  if (code == 'f' && size == 8) return Dtype{Dtype::Kind::kNumber, torch::kFloat64, 8};
  if (code == 'i' && size == 2) return Dtype{Dtype::Kind::kNumber, torch::kInt16, 2};
  if (code == 'i' && size == 4) return Dtype{Dtype::Kind::kNumber, torch::kInt32, 4};
  if (code == 'i' && size == 8) return Dtype{Dtype::Kind::kNumber, torch::kInt64, 8};
  // uint32 has no LibTorch type (SMPL's kintree_table is often stored as uint32): widen.
  if (code == 'u' && size == 4) return Dtype{Dtype::Kind::kUnsigned32, torch::kInt32, 4};
  return std::nullopt;
}

std::string describe_unsupported(const std::string& descr) {
  if (descr == "|O") return "'|O' (Python objects, pickled; save a plain numeric array instead)";
  if (!descr.empty() && descr[0] == '>') return fmt::format("'{}' (big-endian)", descr);
  return fmt::format("'{}'", descr);
}

// A decoded header plus its validated element count and data span.
struct NpyArray {
  detail::NpyHeader header;
  Dtype dtype;
  int64_t count = 1;
  const char* data = nullptr;
};

NpyArray parse_npy(const std::string& bytes, const std::string& what) {
  NpyArray array;
  array.header = detail::parse_npy_header(bytes, what);
  const auto dtype = parse_dtype(array.header.descr);
  if (!dtype) fail("{}: unsupported dtype {}", what, describe_unsupported(array.header.descr));
  array.dtype = *dtype;
  for (int64_t dim : array.header.shape) {
    FSKIN_CHECK(dim == 0 || array.count <= std::numeric_limits<int64_t>::max() / dim /
                                               static_cast<int64_t>(dtype->item_size),
                "{}: shape too large", what);
    array.count *= dim;
  }
  const size_t expected = static_cast<size_t>(array.count) * dtype->item_size;
  const size_t available = bytes.size() - array.header.data_offset;
  FSKIN_CHECK(available == expected,
              "{}: data size mismatch: shape {} of '{}' needs {} bytes, file has {}{}", what,
              shape_string(array.header.shape), array.header.descr, expected, available,
              available < expected ? " (truncated)" : "");
  array.data = bytes.data() + array.header.data_offset;
  return array;
}

std::string utf32_to_utf8(const unsigned char* units, size_t count, const std::string& what) {
  std::string out;
  for (size_t i = 0; i < count; ++i) {
    const uint32_t c = units[4 * i] | (units[4 * i + 1] << 8) | (units[4 * i + 2] << 16) |
                       (static_cast<uint32_t>(units[4 * i + 3]) << 24);
    if (c == 0) break;  // numpy pads shorter strings with NUL
    FSKIN_CHECK(c <= 0x10FFFF && (c < 0xD800 || c > 0xDFFF),
                "{}: invalid unicode code point {:#x} in string array", what, c);
    if (c < 0x80) {
      out += static_cast<char>(c);
    } else if (c < 0x800) {
      out += static_cast<char>(0xC0 | (c >> 6));
      out += static_cast<char>(0x80 | (c & 0x3F));
    } else if (c < 0x10000) {
      out += static_cast<char>(0xE0 | (c >> 12));
      out += static_cast<char>(0x80 | ((c >> 6) & 0x3F));
      out += static_cast<char>(0x80 | (c & 0x3F));
    } else {
      out += static_cast<char>(0xF0 | (c >> 18));
      out += static_cast<char>(0x80 | ((c >> 12) & 0x3F));
      out += static_cast<char>(0x80 | ((c >> 6) & 0x3F));
      out += static_cast<char>(0x80 | (c & 0x3F));
    }
  }
  return out;
}

std::vector<uint32_t> utf8_to_code_points(const std::string& text) {
  std::vector<uint32_t> points;
  for (size_t i = 0; i < text.size();) {
    const auto lead = static_cast<unsigned char>(text[i]);
    const int length = lead < 0x80 ? 1 : (lead >> 5) == 0x6 ? 2 : (lead >> 4) == 0xE ? 3
                                                            : (lead >> 3) == 0x1E ? 4 : 0;
    FSKIN_CHECK(length > 0 && i + length <= text.size(),
                "string '{}' is not valid UTF-8 (byte {})", text, i);
    uint32_t c = length == 1 ? lead : lead & (0x7F >> length);
    for (int k = 1; k < length; ++k) {
      const auto next = static_cast<unsigned char>(text[i + k]);
      FSKIN_CHECK((next & 0xC0) == 0x80, "string '{}' is not valid UTF-8 (byte {})", text, i + k);
      c = (c << 6) | (next & 0x3F);
    }
    points.push_back(c);
    i += length;
  }
  return points;
}

zip_error_t error_from_code(int code) {
  zip_error_t error;
  zip_error_init_with_code(&error, code);
  return error;
}

std::string zip_message(zip_error_t* error) {
  std::string message = zip_error_strerror(error);
  zip_error_fini(error);
  return message;
}

}  // namespace

torch::Tensor decode_npy(const std::string& bytes, const std::string& what) {
  const NpyArray array = parse_npy(bytes, what);
  const Dtype& dtype = array.dtype;
  FSKIN_CHECK(dtype.kind == Dtype::Kind::kNumber || dtype.kind == Dtype::Kind::kUnsigned32,
              "{}: is a string array ('{}'), not a numeric tensor", what, array.header.descr);
  std::vector<int64_t> shape = array.header.shape;
  if (array.header.fortran_order) std::reverse(shape.begin(), shape.end());
  torch::Tensor tensor = torch::empty(shape, torch::TensorOptions().dtype(dtype.scalar));
  if (dtype.scalar == torch::kBool) {
    // Any non-zero byte is true; copying raw bytes could create invalid bool values.
    auto* out = tensor.data_ptr<bool>();
    for (int64_t i = 0; i < array.count; ++i) out[i] = array.data[i] != 0;
  } else if (array.count > 0) {  // an empty tensor has no buffer: memcpy's pointers must not be null
    std::memcpy(tensor.data_ptr(), array.data, static_cast<size_t>(array.count) * dtype.item_size);
  }
  if (dtype.kind == Dtype::Kind::kUnsigned32) {
    // Reinterpret the int32 bits as uint32 and widen to int64 without sign extension.
    tensor = tensor.to(torch::kInt64).bitwise_and(int64_t{0xFFFFFFFF});
  }
  if (array.header.fortran_order && tensor.dim() > 1) {
    std::vector<int64_t> reversed(tensor.dim());
    for (int64_t i = 0; i < tensor.dim(); ++i) reversed[i] = tensor.dim() - 1 - i;
    tensor = tensor.permute(reversed).contiguous();
  }
  return tensor;
}

std::vector<std::string> decode_npy_strings(const std::string& bytes, const std::string& what) {
  const NpyArray array = parse_npy(bytes, what);
  const Dtype& dtype = array.dtype;
  FSKIN_CHECK(dtype.kind == Dtype::Kind::kUnicode || dtype.kind == Dtype::Kind::kBytes,
              "{}: is a numeric array ('{}'), not a string array", what, array.header.descr);
  // Strings are returned in C order; for a 1-D list the memory order does not matter.
  FSKIN_CHECK(!array.header.fortran_order || array.header.shape.size() <= 1,
              "{}: Fortran-ordered multi-dimensional string arrays are not supported", what);
  std::vector<std::string> strings;
  strings.reserve(static_cast<size_t>(array.count));
  const auto* data = reinterpret_cast<const unsigned char*>(array.data);
  for (int64_t i = 0; i < array.count; ++i) {
    const unsigned char* item = data + static_cast<size_t>(i) * dtype.item_size;
    if (dtype.kind == Dtype::Kind::kUnicode) {
      strings.push_back(utf32_to_utf8(item, dtype.item_size / 4, what));
    } else {
      const auto* text = reinterpret_cast<const char*>(item);
      strings.emplace_back(text, strnlen(text, dtype.item_size));
    }
  }
  return strings;
}

std::string encode_npy(const torch::Tensor& tensor) {
  FSKIN_CHECK(tensor.defined(), "encode_npy: tensor is undefined");
  const torch::Tensor cpu = tensor.detach().to(torch::kCPU).contiguous();
  std::string descr;
  switch (cpu.scalar_type()) {
    case torch::kFloat32: descr = "<f4"; break;
    case torch::kFloat64: descr = "<f8"; break;
    case torch::kInt8: descr = "|i1"; break;
    case torch::kInt16: descr = "<i2"; break;
    case torch::kInt32: descr = "<i4"; break;
    case torch::kInt64: descr = "<i8"; break;
    case torch::kUInt8: descr = "|u1"; break;
    case torch::kBool: descr = "|b1"; break;
    default:
      fail("encode_npy: unsupported tensor dtype {} (supported: float32, float64, int8, int16, "
           "int32, int64, uint8, bool)",
           std::string(c10::toString(cpu.scalar_type())));
  }
  std::string out = detail::make_npy_header(descr, cpu.sizes().vec());
  out.append(static_cast<const char*>(cpu.data_ptr()), cpu.nbytes());
  return out;
}

std::string encode_npy_strings(const std::vector<std::string>& strings) {
  std::vector<std::vector<uint32_t>> points;
  size_t width = 1;  // numpy stores an empty string list as '<U1'
  for (const auto& text : strings) {
    points.push_back(utf8_to_code_points(text));
    width = std::max(width, points.back().size());
  }
  std::string data(strings.size() * width * 4, '\0');
  for (size_t i = 0; i < points.size(); ++i) {
    for (size_t k = 0; k < points[i].size(); ++k) {
      for (size_t b = 0; b < 4; ++b) {
        data[(i * width + k) * 4 + b] = static_cast<char>((points[i][k] >> (8 * b)) & 0xFF);
      }
    }
  }
  return detail::make_npy_header("<U" + std::to_string(width),
                                 {static_cast<int64_t>(strings.size())}) +
         data;
}

torch::Tensor read_npy(const std::string& path) { return decode_npy(read_file(path), path); }

void write_npy(const std::string& path, const torch::Tensor& tensor) {
  write_file_atomically(path, encode_npy(tensor));
}

// ---------------------------------------------------------------------------
// NpzReader
// ---------------------------------------------------------------------------

struct NpzReader::Impl {
  zip_t* archive = nullptr;
  std::vector<std::string> member_names;
  std::mutex mutex;  // a zip_t must not be read from two threads at once
  ~Impl() {
    if (archive) zip_discard(archive);
  }
};

NpzReader::NpzReader(const std::string& path) : path_(path), impl_(std::make_unique<Impl>()) {
  FSKIN_CHECK(std::filesystem::exists(path), "{}: cannot open .npz archive: no such file", path);
  int code = 0;
  impl_->archive = zip_open(path.c_str(), ZIP_RDONLY, &code);
  if (!impl_->archive) {
    zip_error_t error = error_from_code(code);
    fail("{}: cannot open as .npz (zip) archive: {}", path, zip_message(&error));
  }
  const zip_int64_t count = zip_get_num_entries(impl_->archive, 0);
  for (zip_int64_t i = 0; i < count; ++i) {
    const char* name = zip_get_name(impl_->archive, static_cast<zip_uint64_t>(i), 0);
    FSKIN_CHECK(name != nullptr, "{}: unreadable member name #{}", path, i);
    // Two members of one name: which one is "the" array would be the reader's
    // choice (libzip finds the first), so the archive is refused.
    FSKIN_CHECK(std::find(impl_->member_names.begin(), impl_->member_names.end(), name) ==
                    impl_->member_names.end(),
                "{}: member '{}' appears more than once", path, name);
    impl_->member_names.emplace_back(name);
  }
}

NpzReader::~NpzReader() = default;
NpzReader::NpzReader(NpzReader&&) noexcept = default;
NpzReader& NpzReader::operator=(NpzReader&&) noexcept = default;

std::vector<std::string> NpzReader::keys() const {
  std::vector<std::string> keys;
  for (const auto& name : impl_->member_names) {
    const bool npy = name.size() > 4 && name.compare(name.size() - 4, 4, ".npy") == 0;
    keys.push_back(npy ? name.substr(0, name.size() - 4) : name);
  }
  std::sort(keys.begin(), keys.end());
  return keys;
}

bool NpzReader::contains(const std::string& key) const {
  const auto& names = impl_->member_names;
  return std::find(names.begin(), names.end(), key + ".npy") != names.end() ||
         std::find(names.begin(), names.end(), key) != names.end();
}

std::string NpzReader::raw(const std::string& key) const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  zip_t* archive = impl_->archive;
  zip_int64_t index = zip_name_locate(archive, (key + ".npy").c_str(), 0);
  if (index < 0) index = zip_name_locate(archive, key.c_str(), 0);
  if (index < 0) {
    fail("{}: no array '{}' in archive (available: {})", path_, key, fmt::join(keys(), ", "));
  }
  zip_stat_t stat;
  zip_stat_init(&stat);
  FSKIN_CHECK(zip_stat_index(archive, static_cast<zip_uint64_t>(index), 0, &stat) == 0 &&
                  (stat.valid & ZIP_STAT_SIZE),
              "{}: array '{}': cannot stat member: {}", path_, key, zip_strerror(archive));
  zip_file_t* file = zip_fopen_index(archive, static_cast<zip_uint64_t>(index), 0);
  FSKIN_CHECK(file != nullptr, "{}: array '{}': cannot open member: {}", path_, key,
              zip_strerror(archive));
  std::string bytes(static_cast<size_t>(stat.size), '\0');
  size_t done = 0;
  std::string problem;
  while (done < bytes.size()) {
    const zip_int64_t n = zip_fread(file, bytes.data() + done, bytes.size() - done);
    if (n < 0) {
      problem = zip_file_strerror(file);
      break;
    }
    if (n == 0) {
      problem = fmt::format("member ends after {} of {} bytes", done, bytes.size());
      break;
    }
    done += static_cast<size_t>(n);
  }
  zip_fclose(file);
  FSKIN_CHECK(problem.empty(), "{}: array '{}': corrupt or truncated member: {}", path_, key,
              problem);
  // libzip checks the CRC only when a read runs past the member's end, which
  // reading exactly its size never does: checked here.
  if (stat.valid & ZIP_STAT_CRC) {
    const auto crc = static_cast<uint32_t>(
        ::crc32(0L, reinterpret_cast<const Bytef*>(bytes.data()), static_cast<uInt>(bytes.size())));
    FSKIN_CHECK(crc == stat.crc, "{}: array '{}': corrupt member (CRC-32 {:08x}, the archive says {:08x})", path_,
                key, crc, stat.crc);
  }
  return bytes;
}

torch::Tensor NpzReader::tensor(const std::string& key) const {
  return decode_npy(raw(key), fmt::format("{}: array '{}'", path_, key));
}

std::vector<std::string> NpzReader::strings(const std::string& key) const {
  return decode_npy_strings(raw(key), fmt::format("{}: array '{}'", path_, key));
}

// ---------------------------------------------------------------------------
// NpzWriter
// ---------------------------------------------------------------------------

void NpzWriter::add(const std::string& key, const torch::Tensor& tensor) {
  FSKIN_CHECK(!key.empty(), "NpzWriter: empty key");
  FSKIN_CHECK(!entries_.count(key), "NpzWriter: key '{}' added twice", key);
  try {
    entries_[key] = encode_npy(tensor);
  } catch (const Error& e) {
    fail("NpzWriter: key '{}': {}", key, e.what());
  }
}

void NpzWriter::add_strings(const std::string& key, const std::vector<std::string>& strings) {
  FSKIN_CHECK(!key.empty(), "NpzWriter: empty key");
  FSKIN_CHECK(!entries_.count(key), "NpzWriter: key '{}' added twice", key);
  try {
    entries_[key] = encode_npy_strings(strings);
  } catch (const Error& e) {
    fail("NpzWriter: key '{}': {}", key, e.what());
  }
}

void NpzWriter::save(const std::string& path, bool compress) const {
  // The archive is built in memory and then written with write_file_atomically, so a
  // killed run never leaves a partial .npz under `path`.
  zip_error_t error;
  zip_error_init(&error);
  zip_source_t* buffer = zip_source_buffer_create(nullptr, 0, 0, &error);
  FSKIN_CHECK(buffer != nullptr, "{}: cannot create zip buffer: {}", path, zip_message(&error));
  zip_t* archive = zip_open_from_source(buffer, ZIP_TRUNCATE, &error);
  if (!archive) {
    zip_source_free(buffer);
    fail("{}: cannot create zip archive: {}", path, zip_message(&error));
  }
  zip_source_keep(buffer);  // keep the bytes alive after zip_close
  auto abandon = [&](const std::string& why) {
    zip_discard(archive);
    zip_source_free(buffer);
    fail("{}: cannot write .npz: {}", path, why);
  };
  // DOS date 1980-01-01 00:00, the zip epoch: fixed so equal content gives equal bytes.
  constexpr zip_uint16_t kDosTime = 0, kDosDate = (0 << 9) | (1 << 5) | 1;
  for (const auto& [key, bytes] : entries_) {  // std::map: sorted keys
    zip_source_t* member = zip_source_buffer(archive, bytes.data(), bytes.size(), 0);
    if (!member) abandon(zip_strerror(archive));
    const zip_int64_t index = zip_file_add(archive, (key + ".npy").c_str(), member, ZIP_FL_ENC_UTF_8);
    if (index < 0) {
      zip_source_free(member);
      abandon(zip_strerror(archive));
    }
    const auto i = static_cast<zip_uint64_t>(index);
    if (zip_set_file_compression(archive, i, compress ? ZIP_CM_DEFLATE : ZIP_CM_STORE, 0) != 0 ||
        zip_file_set_dostime(archive, i, kDosTime, kDosDate, 0) != 0) {
      abandon(zip_strerror(archive));
    }
  }
  if (zip_close(archive) != 0) abandon(zip_strerror(archive));

  std::string bytes;
  zip_stat_t stat;
  bool ok = zip_source_stat(buffer, &stat) == 0 && (stat.valid & ZIP_STAT_SIZE) &&
            zip_source_open(buffer) == 0;
  if (ok) {
    bytes.resize(static_cast<size_t>(stat.size));
    ok = zip_source_read(buffer, bytes.data(), stat.size) == static_cast<zip_int64_t>(stat.size);
    zip_source_close(buffer);
  }
  zip_source_free(buffer);
  FSKIN_CHECK(ok, "{}: cannot read back the in-memory zip archive", path);
  write_file_atomically(path, bytes);
}

}  // namespace fskin::io

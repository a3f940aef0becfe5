#include "fskin/io/npz.h"

#include <torch/torch.h>
#include <zip.h>

#include <cstring>
#include <filesystem>

#include "fskin/core/error.h"
#include "fskin/core/tensor_checks.h"
#include "fskin/util/atomic_file.h"
#include "io/npy_format.h"

namespace fskin::io {

namespace {

struct DtypeInfo {
  const char* code;  // without the byte-order character
  torch::ScalarType type;
  size_t item_size;
};

// The numeric dtypes fskin reads and writes. uint32 is read only (SMPL files
// store kintree_table as uint32) and widened to int64.
constexpr DtypeInfo kDtypes[] = {
    {"f4", torch::kFloat32, 4}, {"f8", torch::kFloat64, 8}, {"i1", torch::kInt8, 1},
    {"i2", torch::kInt16, 2},   {"i4", torch::kInt32, 4},   {"i8", torch::kInt64, 8},
    {"u1", torch::kUInt8, 1},   {"b1", torch::kBool, 1},
};

int64_t element_count(const std::vector<int64_t>& shape) {
  int64_t n = 1;
  for (int64_t d : shape) n *= d;
  return n;
}

void check_payload(const detail::NpyHeader& h, const std::string& bytes, size_t item_size,
                   const std::string& what) {
  const size_t need = static_cast<size_t>(element_count(h.shape)) * item_size;
  FSKIN_CHECK(bytes.size() - h.data_offset >= need,
              "{}: truncated array data ({} bytes, shape {} of '{}' needs {})", what,
              bytes.size() - h.data_offset, shape_string(h.shape), h.descr, need);
}

// Fortran-ordered data is the C-ordered data of the reversed shape, transposed.
torch::Tensor from_buffer(const std::string& bytes, const detail::NpyHeader& h,
                          torch::ScalarType type) {
  std::vector<int64_t> shape = h.shape;
  if (h.fortran_order) std::reverse(shape.begin(), shape.end());
  auto t = torch::empty(shape, torch::TensorOptions().dtype(type));
  std::memcpy(t.data_ptr(), bytes.data() + h.data_offset, t.nbytes());
  if (h.fortran_order && t.dim() > 1) {
    std::vector<int64_t> perm(t.dim());
    for (int64_t i = 0; i < t.dim(); ++i) perm[i] = t.dim() - 1 - i;
    t = t.permute(perm).contiguous();
  }
  return t;
}

std::string utf32_to_utf8(const char32_t* text, size_t max_len) {
  std::string out;
  for (size_t i = 0; i < max_len && text[i] != 0; ++i) {
    const char32_t c = text[i];
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

std::u32string utf8_to_utf32(const std::string& s) {
  std::u32string out;
  for (size_t i = 0; i < s.size();) {
    const unsigned char c = s[i];
    int extra = c < 0x80 ? 0 : c < 0xE0 ? 1 : c < 0xF0 ? 2 : 3;
    char32_t cp = extra == 0 ? c : c & (0x3F >> extra);
    for (int k = 1; k <= extra && i + k < s.size(); ++k) cp = (cp << 6) | (s[i + k] & 0x3F);
    out += cp;
    i += 1 + extra;
  }
  return out;
}

}  // namespace

torch::Tensor decode_npy(const std::string& bytes, const std::string& what) {
  const auto h = detail::parse_npy_header(bytes, what);
  FSKIN_CHECK(h.descr.size() < 2 || h.descr.substr(1) != "O",
              "{}: object arrays (pickled data, dtype '{}') are not supported", what, h.descr);
  FSKIN_CHECK(h.descr.size() >= 3, "{}: unsupported dtype '{}'", what, h.descr);
  const char order = h.descr[0];
  const std::string code = h.descr.substr(1);
  FSKIN_CHECK(order != '>', "{}: big-endian dtype '{}' is not supported; save it little-endian",
              what, h.descr);
  if (code == "u4") {
    check_payload(h, bytes, 4, what);
    return from_buffer(bytes, h, torch::kInt32).to(torch::kInt64).bitwise_and(static_cast<int64_t>(0xffffffff));
  }
  for (const auto& d : kDtypes) {
    if (code == d.code) {
      check_payload(h, bytes, d.item_size, what);
      return from_buffer(bytes, h, d.type);
    }
  }
  fail("{}: unsupported dtype '{}' (supported: float32/64, int8/16/32/64, uint8, uint32, bool)",
       what, h.descr);
}

std::vector<std::string> decode_npy_strings(const std::string& bytes, const std::string& what) {
  const auto h = detail::parse_npy_header(bytes, what);
  FSKIN_CHECK(h.descr.size() >= 3 && h.descr[1] == 'U' && h.descr[0] != '>',
              "{}: expected a little-endian unicode string array ('<U'), got dtype '{}'", what,
              h.descr);
  FSKIN_CHECK(h.shape.size() == 1, "{}: expected a 1-D string array, got shape {}", what,
              shape_string(h.shape));
  const size_t width = std::stoul(h.descr.substr(2));
  check_payload(h, bytes, 4 * width, what);
  std::vector<std::string> out;
  std::vector<char32_t> buffer(width);
  for (int64_t i = 0; i < h.shape[0]; ++i) {
    std::memcpy(buffer.data(), bytes.data() + h.data_offset + i * 4 * width, 4 * width);
    out.push_back(utf32_to_utf8(buffer.data(), width));
  }
  return out;
}

std::string encode_npy(const torch::Tensor& tensor) {
  FSKIN_CHECK(tensor.defined(), "encode_npy: undefined tensor");
  const auto t = tensor.detach().to(torch::kCPU).contiguous();
  const DtypeInfo* info = nullptr;
  for (const auto& d : kDtypes)
    if (d.type == t.scalar_type()) info = &d;
  FSKIN_CHECK(info != nullptr, "encode_npy: unsupported dtype {}",
              std::string(c10::toString(t.scalar_type())));
  const char order = info->item_size == 1 ? '|' : '<';
  std::string out = detail::make_npy_header(std::string(1, order) + info->code, t.sizes().vec());
  out.append(static_cast<const char*>(t.data_ptr()), t.nbytes());
  return out;
}

std::string encode_npy_strings(const std::vector<std::string>& strings) {
  std::vector<std::u32string> wide;
  size_t width = 1;
  for (const auto& s : strings) {
    wide.push_back(utf8_to_utf32(s));
    width = std::max(width, wide.back().size());
  }
  std::string out = detail::make_npy_header("<U" + std::to_string(width),
                                            {static_cast<int64_t>(strings.size())});
  for (const auto& w : wide) {
    std::u32string padded = w;
    padded.resize(width, U'\0');
    out.append(reinterpret_cast<const char*>(padded.data()), 4 * width);
  }
  return out;
}

torch::Tensor read_npy(const std::string& path) { return decode_npy(read_file(path), path); }

void write_npy(const std::string& path, const torch::Tensor& tensor) {
  write_file_atomically(path, encode_npy(tensor));
}

// ---------------------------------------------------------------------------

struct NpzReader::Impl {
  zip_t* archive = nullptr;
  ~Impl() {
    if (archive) zip_discard(archive);
  }
};

NpzReader::NpzReader(const std::string& path) : path_(path), impl_(std::make_unique<Impl>()) {
  FSKIN_CHECK(std::filesystem::exists(path), "{}: no such file", path);
  int error = 0;
  impl_->archive = zip_open(path.c_str(), ZIP_RDONLY | ZIP_CHECKCONS, &error);
  if (!impl_->archive) {
    zip_error_t ze;
    zip_error_init_with_code(&ze, error);
    const std::string why = zip_error_strerror(&ze);
    zip_error_fini(&ze);
    fail("{}: cannot open as .npz (zip) archive: {}", path, why);
  }
}

NpzReader::~NpzReader() = default;
NpzReader::NpzReader(NpzReader&&) noexcept = default;
NpzReader& NpzReader::operator=(NpzReader&&) noexcept = default;

std::vector<std::string> NpzReader::keys() const {
  std::vector<std::string> out;
  const zip_int64_t n = zip_get_num_entries(impl_->archive, 0);
  for (zip_int64_t i = 0; i < n; ++i) {
    std::string name = zip_get_name(impl_->archive, i, 0);
    if (name.size() > 4 && name.substr(name.size() - 4) == ".npy") name.resize(name.size() - 4);
    out.push_back(name);
  }
  return out;
}

bool NpzReader::contains(const std::string& key) const {
  return zip_name_locate(impl_->archive, (key + ".npy").c_str(), 0) >= 0;
}

std::string NpzReader::raw(const std::string& key) const {
  const std::string member = key + ".npy";
  zip_stat_t st;
  if (zip_stat(impl_->archive, member.c_str(), 0, &st) != 0) {
    std::string available;
    for (const auto& k : keys()) available += (available.empty() ? "" : ", ") + k;
    fail("{}: no array '{}' (available: {})", path_, key, available);
  }
  zip_file_t* file = zip_fopen_index(impl_->archive, st.index, 0);
  FSKIN_CHECK(file != nullptr, "{}: cannot read array '{}': {}", path_, key,
              zip_strerror(impl_->archive));
  std::string bytes(st.size, '\0');
  const zip_int64_t got = zip_fread(file, bytes.data(), st.size);
  const std::string why = got < 0 ? zip_file_strerror(file) : "";
  zip_fclose(file);
  FSKIN_CHECK(got == static_cast<zip_int64_t>(st.size),
              "{}: array '{}' is truncated or corrupted ({} of {} bytes read{}{})", path_, key,
              std::max<zip_int64_t>(got, 0), st.size, why.empty() ? "" : ": ", why);
  return bytes;
}

torch::Tensor NpzReader::tensor(const std::string& key) const {
  return decode_npy(raw(key), path_ + ": " + key);
}

std::vector<std::string> NpzReader::strings(const std::string& key) const {
  return decode_npy_strings(raw(key), path_ + ": " + key);
}

// ---------------------------------------------------------------------------

void NpzWriter::add(const std::string& key, const torch::Tensor& tensor) {
  entries_[key] = encode_npy(tensor);
}

void NpzWriter::add_strings(const std::string& key, const std::vector<std::string>& strings) {
  entries_[key] = encode_npy_strings(strings);
}

void NpzWriter::save(const std::string& path, bool compress) const {
  // Build the archive in memory, then write it atomically. Every member gets
  // the same fixed timestamp so equal content gives byte-identical files.
  constexpr time_t kFixedMtime = 315964800;  // 1980-01-06, inside the DOS date range
  zip_error_t error;
  zip_error_init(&error);
  zip_source_t* buffer = zip_source_buffer_create(nullptr, 0, 0, &error);
  FSKIN_CHECK(buffer != nullptr, "{}: cannot create zip buffer: {}", path,
              zip_error_strerror(&error));
  zip_t* archive = zip_open_from_source(buffer, ZIP_TRUNCATE, &error);
  if (!archive) {
    zip_source_free(buffer);
    fail("{}: cannot create zip archive: {}", path, zip_error_strerror(&error));
  }
  zip_source_keep(buffer);  // keep the bytes alive after zip_close
  auto abort_with = [&](const std::string& what) {
    const std::string why = zip_strerror(archive);
    zip_discard(archive);
    zip_source_free(buffer);
    fail("{}: {}: {}", path, what, why);
  };
  for (const auto& [key, bytes] : entries_) {
    zip_source_t* member = zip_source_buffer(archive, bytes.data(), bytes.size(), 0);
    if (!member) abort_with("cannot add '" + key + "'");
    const zip_int64_t index = zip_file_add(archive, (key + ".npy").c_str(), member, ZIP_FL_ENC_UTF_8);
    if (index < 0) {
      zip_source_free(member);
      abort_with("cannot add '" + key + "'");
    }
    if (zip_set_file_compression(archive, index, compress ? ZIP_CM_DEFLATE : ZIP_CM_STORE, 0) != 0 ||
        zip_file_set_mtime(archive, index, kFixedMtime, 0) != 0)
      abort_with("cannot set attributes of '" + key + "'");
  }
  if (zip_close(archive) != 0) abort_with("cannot finish zip archive");

  zip_stat_t st;
  zip_stat_init(&st);
  std::string bytes;
  if (zip_source_stat(buffer, &st) == 0 && zip_source_open(buffer) == 0) {
    bytes.resize(st.size);
    const zip_int64_t got = zip_source_read(buffer, bytes.data(), st.size);
    zip_source_close(buffer);
    if (got != static_cast<zip_int64_t>(st.size)) bytes.clear();
  }
  zip_source_free(buffer);
  FSKIN_CHECK(!bytes.empty(), "{}: cannot read back the zip archive built in memory", path);
  write_file_atomically(path, bytes);
}

}  // namespace fskin::io

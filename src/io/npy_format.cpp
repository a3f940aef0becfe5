#include "io/npy_format.h"

#include <cstring>
#include <regex>

#include "fskin/core/error.h"

namespace fskin::io::detail {

NpyHeader parse_npy_header(const std::string& bytes, const std::string& what) {
  static const char kMagic[] = "\x93NUMPY";
  FSKIN_CHECK(bytes.size() >= 10 && std::memcmp(bytes.data(), kMagic, 6) == 0,
              "{}: not a .npy array (bad magic)", what);
  const int major = static_cast<unsigned char>(bytes[6]);
  size_t header_len = 0, prefix = 0;
  if (major == 1) {
    header_len = static_cast<unsigned char>(bytes[8]) | (static_cast<unsigned char>(bytes[9]) << 8);
    prefix = 10;
  } else if (major == 2 || major == 3) {
    FSKIN_CHECK(bytes.size() >= 12, "{}: truncated .npy header", what);
    uint32_t len = 0;
    std::memcpy(&len, bytes.data() + 8, 4);
    header_len = len;
    prefix = 12;
  } else {
    fail("{}: unsupported .npy format version {}", what, major);
  }
  FSKIN_CHECK(bytes.size() >= prefix + header_len, "{}: truncated .npy header", what);
  const std::string dict = bytes.substr(prefix, header_len);

  NpyHeader header;
  header.data_offset = prefix + header_len;
  std::smatch m;
  FSKIN_CHECK(std::regex_search(dict, m, std::regex(R"('descr'\s*:\s*'([^']*)')")),
              "{}: .npy header has no 'descr' (structured dtypes are not supported): {}", what,
              dict);
  header.descr = m[1];
  FSKIN_CHECK(std::regex_search(dict, m, std::regex(R"('fortran_order'\s*:\s*(True|False))")),
              "{}: .npy header has no 'fortran_order'", what);
  header.fortran_order = m[1] == "True";
  FSKIN_CHECK(std::regex_search(dict, m, std::regex(R"('shape'\s*:\s*\(([^)]*)\))")),
              "{}: .npy header has no 'shape'", what);
  const std::string dims = m[1];
  const std::regex number(R"(\d+)");
  for (auto it = std::sregex_iterator(dims.begin(), dims.end(), number);
       it != std::sregex_iterator(); ++it)
    header.shape.push_back(std::stoll(it->str()));
  return header;
}

std::string make_npy_header(const std::string& descr, const std::vector<int64_t>& shape) {
  std::string dims;
  for (size_t i = 0; i < shape.size(); ++i) dims += std::to_string(shape[i]) + ", ";
  if (shape.size() > 1) dims.resize(dims.size() - 2);  // numpy: (3,) but (3, 4)
  else if (shape.size() == 1) dims.resize(dims.size() - 1);
  std::string dict =
      "{'descr': '" + descr + "', 'fortran_order': False, 'shape': (" + dims + "), }";
  const size_t unpadded = 10 + dict.size() + 1;  // magic+version+len, dict, '\n'
  dict.append((64 - unpadded % 64) % 64, ' ');
  dict += '\n';
  std::string out("\x93NUMPY\x01\x00", 8);
  const uint16_t len = static_cast<uint16_t>(dict.size());
  out.push_back(static_cast<char>(len & 0xff));
  out.push_back(static_cast<char>(len >> 8));
  return out + dict;
}

}  // namespace fskin::io::detail

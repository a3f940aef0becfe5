#include "io/npy_format.h"

#include <fmt/format.h>

#include <cctype>
#include <cstring>
#include <limits>

#include "fskin/core/error.h"

namespace fskin::io::detail {
namespace {

constexpr char kMagic[] = "\x93NUMPY";
constexpr size_t kMagicSize = 6;
constexpr size_t kHeaderAlignment = 64;

// A minimal reader for the Python dict literal of an .npy header: string keys, and
// values that are strings, True/False, or tuples of non-negative integers. A structured
// dtype (a list as 'descr') is captured verbatim so the error can show it.
class HeaderParser {
 public:
  HeaderParser(const std::string& text, const std::string& what) : text_(text), what_(what) {}

  NpyHeader parse() {
    NpyHeader header;
    bool have_descr = false, have_order = false, have_shape = false;
    expect('{');
    while (true) {
      skip_space();
      if (peek() == '}') break;
      const std::string key = string_literal();
      expect(':');
      skip_space();
      if (key == "descr") {
        header.descr = peek() == '[' ? raw_bracketed() : string_literal();
        have_descr = true;
      } else if (key == "fortran_order") {
        header.fortran_order = boolean();
        have_order = true;
      } else if (key == "shape") {
        header.shape = int_tuple();
        have_shape = true;
      } else {
        bad(fmt::format("unexpected key '{}'", key));
      }
      skip_space();
      if (peek() == ',') ++pos_;
    }
    if (!have_descr || !have_order || !have_shape) {
      bad("missing 'descr', 'fortran_order' or 'shape'");
    }
    return header;
  }

 private:
  [[noreturn]] void bad(const std::string& why) const {
    fail("{}: bad .npy header ({}): {}", what_, why, text_);
  }
  void skip_space() {
    while (pos_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[pos_]))) ++pos_;
  }
  char peek() {
    skip_space();
    if (pos_ >= text_.size()) bad("unexpected end");
    return text_[pos_];
  }
  void expect(char c) {
    if (peek() != c) bad(fmt::format("expected '{}' at offset {}", c, pos_));
    ++pos_;
  }
  std::string string_literal() {
    const char quote = peek();
    if (quote != '\'' && quote != '"') bad(fmt::format("expected a string at offset {}", pos_));
    const size_t end = text_.find(quote, pos_ + 1);
    if (end == std::string::npos) bad("unterminated string");
    std::string value = text_.substr(pos_ + 1, end - pos_ - 1);
    pos_ = end + 1;
    return value;
  }
  std::string raw_bracketed() {
    int depth = 0;
    const size_t start = pos_;
    for (; pos_ < text_.size(); ++pos_) {
      if (text_[pos_] == '[') ++depth;
      if (text_[pos_] == ']' && --depth == 0) return text_.substr(start, ++pos_ - start);
    }
    bad("unterminated list");
  }
  bool boolean() {
    skip_space();
    for (const auto& [word, value] : {std::pair{"True", true}, std::pair{"False", false}}) {
      const size_t n = std::strlen(word);
      if (text_.compare(pos_, n, word) == 0) {
        pos_ += n;
        return value;
      }
    }
    bad("'fortran_order' is neither True nor False");
  }
  std::vector<int64_t> int_tuple() {
    std::vector<int64_t> values;
    expect('(');
    while (peek() != ')') {
      if (!std::isdigit(static_cast<unsigned char>(text_[pos_]))) bad("bad shape");
      int64_t value = 0;
      while (pos_ < text_.size() && std::isdigit(static_cast<unsigned char>(text_[pos_]))) {
        if (value > (std::numeric_limits<int64_t>::max() - 9) / 10) bad("shape too large");
        value = value * 10 + (text_[pos_++] - '0');
      }
      // Python 2 wrote long integers as e.g. "3L".
      if (pos_ < text_.size() && text_[pos_] == 'L') ++pos_;
      values.push_back(value);
      if (peek() == ',') ++pos_;
    }
    ++pos_;
    return values;
  }

  const std::string& text_;
  const std::string& what_;
  size_t pos_ = 0;
};

uint32_t read_le32(const std::string& bytes, size_t offset) {
  uint32_t value = 0;
  for (int i = 3; i >= 0; --i) value = (value << 8) | static_cast<unsigned char>(bytes[offset + i]);
  return value;
}

}  // namespace

NpyHeader parse_npy_header(const std::string& bytes, const std::string& what) {
  FSKIN_CHECK(bytes.size() >= kMagicSize + 4 && bytes.compare(0, kMagicSize, kMagic) == 0,
              "{}: not an .npy array (missing \\x93NUMPY magic; {} bytes)", what, bytes.size());
  const int major = static_cast<unsigned char>(bytes[6]);
  size_t header_size = 0, header_start = 0;
  if (major == 1) {
    header_size = static_cast<unsigned char>(bytes[8]) |
                  (static_cast<size_t>(static_cast<unsigned char>(bytes[9])) << 8);
    header_start = 10;
  } else if (major == 2 || major == 3) {
    FSKIN_CHECK(bytes.size() >= 12, "{}: truncated .npy header", what);
    header_size = read_le32(bytes, 8);
    header_start = 12;
  } else {
    fail("{}: unsupported .npy format version {}.{}", what, major,
         static_cast<unsigned char>(bytes[7]));
  }
  FSKIN_CHECK(header_start + header_size <= bytes.size(),
              "{}: truncated .npy header ({} bytes, header says {})", what, bytes.size(),
              header_start + header_size);
  const std::string dict = bytes.substr(header_start, header_size);
  NpyHeader header = HeaderParser(dict, what).parse();
  header.data_offset = header_start + header_size;
  return header;
}

std::string make_npy_header(const std::string& descr, const std::vector<int64_t>& shape) {
  std::string shape_text = "(";
  for (size_t i = 0; i < shape.size(); ++i) {
    // numpy (a tuple's repr): "(3,)" but "(3, 4)".
    shape_text += std::to_string(shape[i]) +
                  (shape.size() == 1 ? "," : i + 1 < shape.size() ? ", " : "");
  }
  shape_text += ")";
  // Byte-for-byte what numpy writes, so files compare equal to np.save output.
  std::string dict =
      fmt::format("{{'descr': '{}', 'fortran_order': False, 'shape': {}, }}", descr, shape_text);
  // Magic, two version bytes and the header length (2 bytes in version 1.0, 4 in 2.0).
  auto padded_length = [&](size_t prefix) {
    const size_t total = (prefix + dict.size() + 1 + kHeaderAlignment - 1) / kHeaderAlignment *
                         kHeaderAlignment;
    return total - prefix;
  };
  const bool version1 = padded_length(kMagicSize + 4) <= 0xFFFF;
  const size_t prefix = kMagicSize + (version1 ? 4 : 6);
  dict.append(padded_length(prefix) - dict.size() - 1, ' ');
  dict += '\n';
  std::string out(kMagic, kMagicSize);
  out += static_cast<char>(version1 ? 1 : 2);
  out += '\0';
  const size_t length = dict.size();
  for (size_t i = 0; i < (version1 ? 2u : 4u); ++i) out += static_cast<char>((length >> (8 * i)) & 0xFF);
  return out + dict;
}

}  // namespace fskin::io::detail

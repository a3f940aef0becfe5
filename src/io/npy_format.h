#pragma once
// Private: the .npy header (magic, version, Python dict literal) shared by npz.cpp.
// Format: https://numpy.org/doc/stable/reference/generated/numpy.lib.format.html
#include <cstdint>
#include <string>
#include <vector>

namespace fskin::io::detail {

struct NpyHeader {
  std::string descr;  // e.g. "<f4", "|u1", "<U12"; a structured dtype's list verbatim
  bool fortran_order = false;
  std::vector<int64_t> shape;
  size_t data_offset = 0;  // bytes from the start of the .npy payload
};

// Parses magic, version (1.0, 2.0, 3.0) and the header dict; throws fskin::Error
// naming `what` for a bad magic, an unknown version, a truncated or malformed header.
NpyHeader parse_npy_header(const std::string& bytes, const std::string& what);

// Header bytes exactly as numpy writes them: version 1.0 (2.0 when the dict does not
// fit 64 KiB), padded with spaces and '\n' so the data starts 64-byte aligned.
std::string make_npy_header(const std::string& descr, const std::vector<int64_t>& shape);

}  // namespace fskin::io::detail

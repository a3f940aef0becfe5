#pragma once
// Private: the .npy header grammar and dtype table shared by npz.cpp.
#include <torch/types.h>

#include <string>
#include <vector>

namespace fskin::io::detail {

struct NpyHeader {
  std::string descr;           // e.g. "<f4", "|u1", "<U12"
  bool fortran_order = false;
  std::vector<int64_t> shape;
  size_t data_offset = 0;      // bytes from the start of the .npy payload
};

// Parses magic, version and the header dict; throws fskin::Error naming `what`.
NpyHeader parse_npy_header(const std::string& bytes, const std::string& what);

// Header bytes (version 1.0, 64-byte aligned as numpy writes them).
std::string make_npy_header(const std::string& descr, const std::vector<int64_t>& shape);

}  // namespace fskin::io::detail

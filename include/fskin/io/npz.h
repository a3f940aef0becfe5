#pragma once
// NumPy .npy / .npz reading and writing (the format of SMPL-family model files
// and of fskin datasets). Supported dtypes: float32, float64, int8, int16,
// int32, int64, uint8, bool, and little-endian unicode strings ('<U') for name
// lists. Reading also accepts uint32 (widened to int64: SMPL's kintree_table),
// byte strings ('|S'), Fortran-ordered arrays (returned C-contiguous) and header
// versions 1.0 to 3.0. Archives may be stored or deflate-compressed (np.savez and
// np.savez_compressed). Any other dtype (big-endian, pickled objects, ...), a
// truncated file, a bad header or a missing key is reported as fskin::Error
// naming the file and the array. An NpzReader may be shared between threads.
#include <torch/types.h>

#include <map>
#include <memory>
#include <string>
#include <vector>

namespace fskin::io {

// Decode one .npy payload (the bytes of a .npy file). `what` names it in errors.
torch::Tensor decode_npy(const std::string& bytes, const std::string& what);
std::vector<std::string> decode_npy_strings(const std::string& bytes, const std::string& what);
// Encode a contiguous CPU tensor / a list of strings as .npy bytes.
std::string encode_npy(const torch::Tensor& tensor);
std::string encode_npy_strings(const std::vector<std::string>& strings);

torch::Tensor read_npy(const std::string& path);
void write_npy(const std::string& path, const torch::Tensor& tensor);

// Read access to an .npz archive; arrays are decoded on demand.
class NpzReader {
 public:
  explicit NpzReader(const std::string& path);  // throws if missing / not a zip
  ~NpzReader();
  NpzReader(NpzReader&&) noexcept;
  NpzReader& operator=(NpzReader&&) noexcept;

  const std::string& path() const { return path_; }
  std::vector<std::string> keys() const;  // without the ".npy" suffix
  bool contains(const std::string& key) const;
  torch::Tensor tensor(const std::string& key) const;  // throws naming file + key
  std::vector<std::string> strings(const std::string& key) const;

 private:
  std::string raw(const std::string& key) const;
  std::string path_;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Everything an NpzWriter holds: tensors and string lists by key.
class NpzWriter {
 public:
  void add(const std::string& key, const torch::Tensor& tensor);
  void add_strings(const std::string& key, const std::vector<std::string>& strings);
  // Writes atomically (temporary file + rename). Deterministic: same content ->
  // same bytes (fixed timestamps, sorted keys).
  void save(const std::string& path, bool compress = true) const;

 private:
  std::map<std::string, std::string> entries_;  // key -> .npy bytes
};

}  // namespace fskin::io

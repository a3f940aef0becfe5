#include "fskin/util/atomic_file.h"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "fskin/core/error.h"

namespace fskin {

void write_file_atomically(const std::string& path,
                           const std::function<void(std::ostream&)>& write) {
  namespace fs = std::filesystem;
  const fs::path target(path);
  if (target.has_parent_path()) fs::create_directories(target.parent_path());
  const std::string tmp = path + ".tmp-" + std::to_string(::getpid());
  try {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    FSKIN_CHECK(out.good(), "{}: cannot open for writing: {}", tmp, std::strerror(errno));
    write(out);
    out.flush();
    FSKIN_CHECK(out.good(), "{}: write failed: {}", tmp, std::strerror(errno));
  } catch (...) {
    std::remove(tmp.c_str());  // never leave a partial file behind
    throw;
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const std::string why = std::strerror(errno);
    std::remove(tmp.c_str());
    fail("{}: cannot rename temporary file into place: {}", path, why);
  }
}

void write_file_atomically(const std::string& path, const std::string& bytes) {
  write_file_atomically(path, [&](std::ostream& out) {
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  });
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  FSKIN_CHECK(in.good(), "{}: cannot open: {}", path,
              std::filesystem::exists(path) ? std::strerror(errno) : "no such file");
  std::ostringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

}  // namespace fskin

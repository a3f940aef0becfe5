#include "fskin/util/atomic_file.h"

#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "fskin/core/error.h"

namespace fskin {

void create_output_directory(const std::string& dir) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::is_directory(dir, ec)) return;
  fs::create_directories(dir, ec);
  if (ec) fail("{}: cannot create the directory: {}", dir, ec.message());
  FSKIN_CHECK(fs::is_directory(dir, ec), "{}: cannot create the directory: a file of that name is in the way", dir);
}

void check_output_apart_from_input(const std::string& output, const std::string& input, const std::string& command) {
  namespace fs = std::filesystem;
  if (output.empty() || input.empty()) return;
  std::error_code ec;
  const fs::path out = fs::weakly_canonical(output, ec), in = fs::weakly_canonical(input, ec);
  if (ec) return;
  const auto inside = [](const fs::path& inner, const fs::path& outer) {
    const auto mismatch = std::mismatch(outer.begin(), outer.end(), inner.begin(), inner.end());
    return mismatch.first == outer.end();
  };
  FSKIN_CHECK(!inside(out, in) && !inside(in, out),
              "{}: the output {} {} the input {}; write it somewhere else", command, output,
              out == in ? "is" : inside(out, in) ? "lies inside" : "holds", input);
}

void write_file_atomically(const std::string& path,
                           const std::function<void(std::ostream&)>& write) {
  namespace fs = std::filesystem;
  const fs::path target(path);
  if (target.has_parent_path()) create_output_directory(target.parent_path().string());
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

int remove_stale_temporaries(const std::string& dir) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return 0;
  int removed = 0;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const std::string name = entry.path().filename().string();
    const auto at = name.rfind(".tmp-");
    if (at == std::string::npos || at + 5 >= name.size()) continue;
    const std::string digits = name.substr(at + 5);
    if (digits.find_first_not_of("0123456789") != std::string::npos || digits.size() > 9) continue;
    const auto pid = static_cast<pid_t>(std::stol(digits));
    const bool owner_alive = pid == ::getpid() || ::kill(pid, 0) == 0 || errno == EPERM;
    if (!owner_alive && fs::remove(entry.path(), ec)) ++removed;
  }
  return removed;
}

std::string read_file(const std::string& path) {
  std::error_code ec;
  FSKIN_CHECK(!std::filesystem::is_directory(path, ec), "{}: is a directory, not a file", path);
  std::ifstream in(path, std::ios::binary);
  FSKIN_CHECK(in.good(), "{}: cannot open: {}", path,
              std::filesystem::exists(path) ? std::strerror(errno) : "no such file");
  std::ostringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

}  // namespace fskin

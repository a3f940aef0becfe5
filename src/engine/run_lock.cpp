#include "fskin/engine/run_lock.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>

#include "fskin/core/error.h"
#include "fskin/util/atomic_file.h"

namespace fskin {

std::string RunLock::path_in(const std::string& run_dir) { return (std::filesystem::path(run_dir) / ".lock").string(); }

RunLock::RunLock(const std::string& run_dir) {
  create_output_directory(run_dir);
  const std::string path = path_in(run_dir);
  fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  FSKIN_CHECK(fd_ >= 0, "{}: cannot open the run's lock file: {}", path, std::strerror(errno));
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    const int error = errno;
    char holder[32] = {0};
    const ssize_t n = ::pread(fd_, holder, sizeof holder - 1, 0);
    ::close(fd_);
    fd_ = -1;
    FSKIN_CHECK(error == EWOULDBLOCK, "{}: cannot lock the run: {}", path, std::strerror(error));
    std::string pid = n > 0 ? std::string(holder, static_cast<size_t>(n)) : std::string("unknown");
    pid = pid.substr(0, pid.find_first_of(" \n"));
    fail("{}: another fskin process (PID {}) is writing this run; wait for it to end or stop it (one writer per run)",
         run_dir, pid);
  }
  const std::string pid = std::to_string(::getpid()) + "\n";
  if (::ftruncate(fd_, 0) != 0 || ::pwrite(fd_, pid.data(), pid.size(), 0) != static_cast<ssize_t>(pid.size())) {
    // The PID is for messages only; the lock itself is held.
  }
}

RunLock::~RunLock() {
  if (fd_ >= 0) ::close(fd_);  // releases the flock
}

}  // namespace fskin

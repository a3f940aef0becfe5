#pragma once
// One writer per run directory. Training, avatar training and their
// --resume hold an advisory lock (flock) on "<run>/.lock" for as long as they
// write the run; a second writer fails at once with an error naming the
// holder's PID. The kernel drops the lock when the holder exits, however it
// exits (kill -9 included), so a killed run never leaves a stale lock.
#include <string>

namespace fskin {

class RunLock {
 public:
  // Creates `run_dir` if needed and takes its lock; throws fskin::Error
  // naming the directory and the holder's PID if another process holds it.
  explicit RunLock(const std::string& run_dir);
  ~RunLock();
  RunLock(const RunLock&) = delete;
  RunLock& operator=(const RunLock&) = delete;

  // The lock file of a run directory.
  static std::string path_in(const std::string& run_dir);

 private:
  int fd_ = -1;
};

}  // namespace fskin

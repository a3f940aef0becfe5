#pragma once
// Files that are either completely written or not there at all: data goes to
// "<path>.tmp-<pid>", is flushed, then renamed over <path> (rename is atomic
// on POSIX file systems). A killed run never leaves a half-written checkpoint,
// dataset frame or mesh under the final name.
#include <functional>
#include <ostream>
#include <string>

namespace fskin {

// Creates `dir` and its parents if missing; throws fskin::Error naming the
// path when it cannot (read-only, under a regular file, no permission).
void create_output_directory(const std::string& dir);

// Throws fskin::Error if `output` is `input`, lies inside it or holds it: a
// run or dataset written over its own input destroys it. `command` names the
// caller in the message.
void check_output_apart_from_input(const std::string& output, const std::string& input, const std::string& command);

// Writes `bytes` to `path` atomically; creates parent directories.
void write_file_atomically(const std::string& path, const std::string& bytes);

// Calls `write(stream)` on a temporary file, then renames it to `path`.
void write_file_atomically(const std::string& path,
                           const std::function<void(std::ostream&)>& write);

// Removes the temporaries ("*.tmp-<pid>") in `dir` that no running process
// owns: what a run killed in the middle of a write (kill -9, power loss)
// leaves behind. Returns how many were removed.
int remove_stale_temporaries(const std::string& dir);

// Whole file as bytes; throws fskin::Error naming `path` if it cannot be read.
std::string read_file(const std::string& path);

}  // namespace fskin

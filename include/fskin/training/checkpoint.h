#pragma once
// Crash-safe training checkpoints.
//
// A checkpoint file is  "FSKINCK1" | u64 payload size | u32 CRC-32 | payload,
// where the payload is a LibTorch archive (modules, optimiser state, step, ...).
// Files are written atomically (temporary name + rename) and the newest `keep`
// are kept, so a run killed at any moment leaves at least one complete
// checkpoint; a truncated or corrupted file is detected by its size/CRC and the
// previous checkpoint is used instead.
#include <torch/serialize.h>

#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace fskin {

using ArchiveWriter = std::function<void(torch::serialize::OutputArchive&)>;
using ArchiveReader = std::function<void(torch::serialize::InputArchive&)>;

// Writes <dir>/checkpoint-<step, 8 digits>.fskin and deletes all but the newest `keep`.
// Returns the path written.
std::string save_checkpoint(const std::string& dir, int64_t step, const ArchiveWriter& write,
                            int keep = 2);

// Checkpoint files in `dir`, newest (highest step) first.
std::vector<std::string> list_checkpoints(const std::string& dir);

// Loads the newest checkpoint that is intact, calling `read` on it; damaged ones
// (bad framing, CRC, archive) are reported on stderr and skipped. Returns its
// path, or nullopt if none. Throws fskin::Error naming the file when `read`
// throws on an intact one.
std::optional<std::string> load_latest_checkpoint(const std::string& dir,
                                                  const ArchiveReader& read);

// Verifies framing and CRC of one file and returns its payload; throws
// fskin::Error naming the file and the damage.
std::string read_checkpoint_payload(const std::string& path);

}  // namespace fskin

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

// Writes one checkpoint file at `path` (atomically, framed and CRC'd as above).
void write_checkpoint_file(const std::string& path, const ArchiveWriter& write);

// <dir>/checkpoint-best.fskin: the checkpoint the trainer keeps for the best
// validation score (outside the numbered rotation, never deleted by it).
std::string best_checkpoint_path(const std::string& dir);

// Which checkpoint of a run to load: the newest intact one, a given step, or
// the best on the validation split.
struct CheckpointChoice {
  enum class Kind { Latest, Step, Best };
  Kind kind = Kind::Latest;
  int64_t step = 0;  // Kind::Step
  // "latest", "best" or a step number; throws fskin::Error naming `text`.
  static CheckpointChoice parse(const std::string& text);
  std::string describe() const;  // "latest", "best", "step 1200"
};

// The file `choice` names in `dir`: for Latest the newest intact one (nullopt
// when there is none); for Step and Best that file, or fskin::Error listing
// the checkpoints there.
std::optional<std::string> find_checkpoint(const std::string& dir, const CheckpointChoice& choice);

// Checkpoint files in `dir`, newest (highest step) first.
std::vector<std::string> list_checkpoints(const std::string& dir);

// Loads the newest checkpoint that is intact, calling `read` on it; damaged ones
// (bad framing, CRC, archive) are reported on stderr and skipped. Returns its
// path, or nullopt if none. Throws fskin::Error naming the file when `read`
// throws on an intact one.
std::optional<std::string> load_latest_checkpoint(const std::string& dir,
                                                  const ArchiveReader& read);

// Loads the checkpoint at `path`, calling `read` on it; throws fskin::Error
// naming the file when it is damaged or does not fit `read`.
void load_checkpoint(const std::string& path, const ArchiveReader& read);

// Verifies framing and CRC of one file and returns its payload; throws
// fskin::Error naming the file and the damage.
std::string read_checkpoint_payload(const std::string& path);

// The part `key` of a model's archive in a checkpoint, which the run's
// settings say it holds (`what`: what the run does that needs it); throws
// fskin::Error naming the run and the part when it is missing.
torch::serialize::InputArchive checkpoint_part(torch::serialize::InputArchive& archive, const char* key,
                                               const std::string& run_dir, const char* what);

}  // namespace fskin

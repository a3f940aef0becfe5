#include "fskin/engine/checkpoint.h"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <torch/torch.h>
#include <zlib.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <sstream>

#include "fskin/core/error.h"
#include "fskin/util/atomic_file.h"

namespace fskin {

namespace fs = std::filesystem;

namespace {
constexpr char kMagic[8] = {'F', 'S', 'K', 'I', 'N', 'C', 'K', '1'};
constexpr size_t kHeaderSize = 8 + 8 + 4;

uint32_t crc32_of(const std::string& bytes) {
  return static_cast<uint32_t>(
      ::crc32(0L, reinterpret_cast<const Bytef*>(bytes.data()), static_cast<uInt>(bytes.size())));
}

int64_t step_of(const fs::path& path) {
  const std::string name = path.filename().string();
  const std::string prefix = "checkpoint-", suffix = ".fskin";
  if (name.size() <= prefix.size() + suffix.size() || name.rfind(prefix, 0) != 0 ||
      name.substr(name.size() - suffix.size()) != suffix)
    return -1;
  const std::string digits = name.substr(prefix.size(), name.size() - prefix.size() - suffix.size());
  if (digits.empty() || digits.size() > 18 || !std::all_of(digits.begin(), digits.end(), ::isdigit)) return -1;
  return std::stoll(digits);
}
}  // namespace

void write_checkpoint_file(const std::string& path, const ArchiveWriter& write) {
  torch::serialize::OutputArchive archive;
  write(archive);
  std::ostringstream payload_stream;
  archive.save_to(payload_stream);
  const std::string payload = payload_stream.str();

  std::string bytes(kMagic, sizeof(kMagic));
  const uint64_t size = payload.size();
  const uint32_t crc = crc32_of(payload);
  bytes.append(reinterpret_cast<const char*>(&size), sizeof(size));
  bytes.append(reinterpret_cast<const char*>(&crc), sizeof(crc));
  bytes += payload;
  write_file_atomically(path, bytes);
}

std::string save_checkpoint(const std::string& dir, int64_t step, const ArchiveWriter& write, int keep) {
  const std::string path = (fs::path(dir) / fmt::format("checkpoint-{:08d}.fskin", step)).string();
  write_checkpoint_file(path, write);
  const auto all = list_checkpoints(dir);
  for (size_t i = static_cast<size_t>(std::max(keep, 1)); i < all.size(); ++i)
    fs::remove(all[i]);
  return path;
}

std::string best_checkpoint_path(const std::string& dir) {
  return (fs::path(dir) / "checkpoint-best.fskin").string();
}

CheckpointChoice CheckpointChoice::parse(const std::string& text) {
  CheckpointChoice choice;
  if (text == "latest") return choice;
  if (text == "best") {
    choice.kind = Kind::Best;
    return choice;
  }
  FSKIN_CHECK(!text.empty() && text.size() <= 18 && std::all_of(text.begin(), text.end(), ::isdigit),
              "--checkpoint '{}': expected a step number, 'latest' or 'best'", text);
  choice.kind = Kind::Step;
  choice.step = std::stoll(text);
  return choice;
}

std::string CheckpointChoice::describe() const {
  switch (kind) {
    case Kind::Latest: return "latest";
    case Kind::Best: return "best";
    case Kind::Step: return fmt::format("step {}", step);
  }
  return "latest";
}

std::optional<std::string> find_checkpoint(const std::string& dir, const CheckpointChoice& choice) {
  const auto numbered = list_checkpoints(dir);
  std::vector<std::string> steps;
  for (const auto& path : numbered) steps.push_back(std::to_string(step_of(path)));
  const std::string available = steps.empty() ? "none" : fmt::format("steps {}", fmt::join(steps, ", "));
  switch (choice.kind) {
    case CheckpointChoice::Kind::Latest:
      return numbered.empty() ? std::nullopt : std::optional<std::string>(numbered.front());
    case CheckpointChoice::Kind::Best: {
      const auto path = best_checkpoint_path(dir);
      FSKIN_CHECK(fs::exists(path),
                  "{}: no best checkpoint (the run was trained without validation; train with --set "
                  "validate_every=N). Numbered checkpoints: {}",
                  dir, available);
      return path;
    }
    case CheckpointChoice::Kind::Step:
      for (const auto& path : numbered) {
        if (step_of(path) == choice.step) return path;
      }
      fail("{}: no checkpoint of step {} (kept: {}; keep_checkpoints sets how many are kept)", dir, choice.step,
           available);
  }
  return std::nullopt;
}

std::vector<std::string> list_checkpoints(const std::string& dir) {
  std::vector<std::pair<int64_t, std::string>> found;
  if (!fs::is_directory(dir)) return {};
  for (const auto& entry : fs::directory_iterator(dir)) {
    const int64_t step = step_of(entry.path());
    if (step >= 0 && entry.is_regular_file()) found.emplace_back(step, entry.path().string());
  }
  std::sort(found.begin(), found.end(), std::greater<>());
  std::vector<std::string> out;
  for (auto& f : found) out.push_back(std::move(f.second));
  return out;
}

std::string read_checkpoint_payload(const std::string& path) {
  const std::string bytes = read_file(path);
  FSKIN_CHECK(bytes.size() >= kHeaderSize && std::memcmp(bytes.data(), kMagic, 8) == 0,
              "{}: not an fskin checkpoint (bad header)", path);
  uint64_t size = 0;
  uint32_t crc = 0;
  std::memcpy(&size, bytes.data() + 8, sizeof(size));
  std::memcpy(&crc, bytes.data() + 16, sizeof(crc));
  FSKIN_CHECK(bytes.size() - kHeaderSize == size,
              "{}: truncated checkpoint ({} payload bytes, header says {})", path,
              bytes.size() - kHeaderSize, size);
  std::string payload = bytes.substr(kHeaderSize);
  FSKIN_CHECK(crc32_of(payload) == crc, "{}: corrupted checkpoint (CRC mismatch)", path);
  return payload;
}

namespace {
// LibTorch's errors carry a C++ stack trace that says nothing to a user.
std::string first_line(const std::string& text) { return text.substr(0, text.find('\n')); }

std::string message_of(const std::exception& e) {
  if (const auto* c10_error = dynamic_cast<const c10::Error*>(&e)) return c10_error->what_without_backtrace();
  return e.what();
}

// Calls `read` on an intact archive; an error there means the file does not
// fit this model (another model or fskin version), not damage.
void read_intact(const std::string& path, torch::serialize::InputArchive& archive, const ArchiveReader& read) {
  try {
    read(archive);
  } catch (const c10::Error& e) {
    throw Error(fmt::format("{}: intact checkpoint that does not fit this model: {}", path,
                            e.what_without_backtrace()));
  } catch (const std::exception& e) {
    throw Error(fmt::format("{}: intact checkpoint that does not fit this model: {}", path, e.what()));
  }
}
}  // namespace

void load_checkpoint(const std::string& path, const ArchiveReader& read) {
  torch::serialize::InputArchive archive;
  const std::string payload = read_checkpoint_payload(path);
  try {
    archive.load_from(payload.data(), payload.size(), torch::kCPU);  // a GPU-trained run loads anywhere
  } catch (const std::exception& e) {
    fail("{}: damaged checkpoint (its archive does not load: {})", path, first_line(message_of(e)));
  }
  read_intact(path, archive, read);
}

std::optional<std::string> load_latest_checkpoint(const std::string& dir, const ArchiveReader& read) {
  for (const auto& path : list_checkpoints(dir)) {
    torch::serialize::InputArchive archive;
    try {
      const std::string payload = read_checkpoint_payload(path);
      archive.load_from(payload.data(), payload.size(), torch::kCPU);  // a GPU-trained run loads anywhere
    } catch (const std::exception& e) {
      std::fprintf(stderr, "fskin: skipping damaged checkpoint: %s\n", first_line(message_of(e)).c_str());
      continue;
    }
    // Falling back to an older checkpoint when an intact one does not fit
    // would silently lose training: that is an error.
    read_intact(path, archive, read);
    return path;
  }
  return std::nullopt;
}

torch::serialize::InputArchive checkpoint_part(torch::serialize::InputArchive& archive, const char* key,
                                               const std::string& run_dir, const char* what) {
  torch::serialize::InputArchive part;
  FSKIN_CHECK(archive.try_read(key, part), "{}: the run {} but its checkpoint holds no '{}'", run_dir, what, key);
  return part;
}

}  // namespace fskin

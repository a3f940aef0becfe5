#include "fskin/data/clip_selection.h"

#include <torch/torch.h>

#include <algorithm>
#include <cctype>
#include <sstream>

#include "fskin/core/error.h"

namespace fskin {
namespace {

// A whole number of at most 9 digits; false for anything else.
bool parse_frame(const std::string& text, int64_t& value) {
  if (text.empty() || text.size() > 9 || !std::all_of(text.begin(), text.end(), ::isdigit)) return false;
  value = std::stoll(text);
  return true;
}

int64_t clip_length(const PoseSet& clips, size_t c) {
  return (c + 1 < clips.clip_starts.size() ? clips.clip_starts[c + 1] : clips.size()) - clips.clip_starts[c];
}

std::string clip_listing(const PoseSet& clips) {
  std::string listing;
  for (size_t c = 0; c < clips.clip_names.size(); ++c)
    listing += fmt::format("{}{} ({} frames)", c ? ", " : "", clips.clip_names[c], clip_length(clips, c));
  return listing;
}

std::string range_name(const ClipRange& range, int64_t length) {
  const int64_t last = range.last < 0 ? length - 1 : range.last;
  if (range.first == 0 && last == length - 1) return range.clip;
  return fmt::format("{}:{}-{}", range.clip, range.first, last);
}

}  // namespace

std::vector<ClipRange> parse_clip_selection(const std::string& selection) {
  std::vector<ClipRange> ranges;
  FSKIN_CHECK(selection.empty() || selection.back() != ',',
              "clip selection '{}': an empty item (two commas, or a comma at an end)", selection);
  std::stringstream items(selection);
  std::string item;
  while (std::getline(items, item, ',')) {
    FSKIN_CHECK(!item.empty(), "clip selection '{}': an empty item (two commas, or a comma at an end)", selection);
    ClipRange range;
    const auto colon = item.rfind(':');
    range.clip = item.substr(0, colon);
    if (colon != std::string::npos) {
      const std::string frames = item.substr(colon + 1);
      const auto dash = frames.find('-');
      const bool ok = dash != std::string::npos && parse_frame(frames.substr(0, dash), range.first) &&
                      (dash + 1 == frames.size() || parse_frame(frames.substr(dash + 1), range.last));
      FSKIN_CHECK(ok && (range.last < 0 || range.last >= range.first),
                  "clip selection '{}': '{}' is not NAME, NAME:FIRST-LAST or NAME:FIRST- (frames from 0, "
                  "inclusive, FIRST <= LAST)",
                  selection, item);
    }
    FSKIN_CHECK(!range.clip.empty(), "clip selection '{}': '{}' names no clip", selection, item);
    ranges.push_back(range);
  }
  FSKIN_CHECK(!ranges.empty(), "clip selection '{}': names no clip", selection);
  return ranges;
}

std::vector<int64_t> selected_frames(const PoseSet& clips, const std::vector<ClipRange>& ranges,
                                     const std::string& source) {
  FSKIN_CHECK(!clips.clip_names.empty(),
              "{}: has no clip names (not a clips file; `fskin import --clips` and `fskin character --clips` write "
              "them)",
              source);
  std::vector<int64_t> frames;
  for (const auto& range : ranges) {
    const auto it = std::find(clips.clip_names.begin(), clips.clip_names.end(), range.clip);
    FSKIN_CHECK(it != clips.clip_names.end(), "{}: no clip named '{}'; its clips: {}", source, range.clip,
                clip_listing(clips));
    const auto c = static_cast<size_t>(it - clips.clip_names.begin());
    const int64_t length = clip_length(clips, c);
    const int64_t last = range.last < 0 ? length - 1 : range.last;
    FSKIN_CHECK(range.first < length && last < length, "{}: clip '{}' has frames 0-{}, not {}-{}", source, range.clip,
                length - 1, range.first, last);
    for (int64_t f = range.first; f <= last; ++f) frames.push_back(clips.clip_starts[c] + f);
  }
  return frames;
}

PoseSet select_clips(const PoseSet& clips, const std::vector<ClipRange>& ranges, const std::string& source) {
  const auto frames = selected_frames(clips, ranges, source);
  const auto index = torch::tensor(frames, torch::kInt64);
  PoseSet out;
  out.poses = clips.poses.index_select(0, index);
  out.trans = clips.trans.index_select(0, index);
  if (clips.joint_translations.defined()) out.joint_translations = clips.joint_translations.index_select(0, index);
  out.joint_names = clips.joint_names;
  int64_t start = 0;
  for (const auto& range : ranges) {
    const auto c = static_cast<size_t>(std::find(clips.clip_names.begin(), clips.clip_names.end(), range.clip) -
                                       clips.clip_names.begin());
    const int64_t length = clip_length(clips, c);
    out.clip_names.push_back(range_name(range, length));
    out.clip_starts.push_back(start);
    start += (range.last < 0 ? length - 1 : range.last) - range.first + 1;
  }
  return out;
}

}  // namespace fskin

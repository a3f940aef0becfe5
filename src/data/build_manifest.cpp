#include "fskin/data/build_manifest.h"

#include <filesystem>

#include "fskin/core/error.h"
#include "fskin/util/atomic_file.h"

namespace fskin {

BuildManifest::BuildManifest(const std::string& dir, nlohmann::json manifest) : manifest_(std::move(manifest)) {
  namespace fs = std::filesystem;
  create_output_directory(dir);
  path_ = (fs::path(dir) / "manifest.json").string();
  if (fs::exists(path_)) {
    nlohmann::json previous;
    try {
      previous = nlohmann::json::parse(read_file(path_));
    } catch (const nlohmann::json::exception& e) {
      fail("{}: not a valid manifest ({}); remove it or use another --out", path_, e.what());
    }
    previous.erase("complete");
    FSKIN_CHECK(previous == manifest_,
                "{} was built with different inputs or parameters; use another --out directory or remove the old "
                "dataset",
                dir);
  }
  remove_stale_temporaries(dir);
  write(false);
}

void BuildManifest::write(bool complete) const {
  auto copy = manifest_;
  copy["complete"] = complete;
  write_file_atomically(path_, copy.dump(2) + "\n");
}

}  // namespace fskin

#pragma once
// The manifest.json of a resumable dataset build (posed scans, image
// datasets): opening it refuses a directory that was built with other
// inputs or parameters (everything but "complete" must match), removes the
// temporaries an interrupted build left, and writes the manifest with
// "complete": false; mark_complete() rewrites it with true once every file
// is there. Readers refuse incomplete datasets.
#include <nlohmann/json.hpp>

#include <string>

namespace fskin {

class BuildManifest {
 public:
  // Throws fskin::Error naming `dir` when its manifest differs from `manifest`.
  BuildManifest(const std::string& dir, nlohmann::json manifest);
  void mark_complete() const { write(true); }
  const std::string& path() const { return path_; }

 private:
  void write(bool complete) const;
  std::string path_;
  nlohmann::json manifest_;
};

}  // namespace fskin

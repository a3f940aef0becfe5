#pragma once
// The tiny image dataset (tiny_image_dataset.h) with its first training
// pose's subject at `scale` of its brightness: one frame lit differently from
// the others, which a per-frame appearance code can hold and a colour shared
// by every frame cannot. Shared by the volume and the Gaussian avatars' tests.
#include <torch/torch.h>

#include <cstdint>
#include <filesystem>
#include <string>

#include "fskin/export/image.h"
#include "fskin/radiance/image_dataset.h"
#include "test_util.h"
#include "tiny_image_dataset.h"

namespace fskin::testing {

inline std::string dataset_with_a_dark_frame(const std::string& name, double scale) {
  namespace fs = std::filesystem;
  const auto& tiny = tiny_image_dataset();
  const auto dir = temp_dir(name) / "images";
  fs::remove_all(dir);
  fs::copy(tiny.dir, dir, fs::copy_options::recursive);
  const ImageDataset data(dir.string());
  const auto split = data.load_split("train");
  for (int64_t i = 0; i < split.size(); ++i) {
    if (split.pose_index[i].item<int64_t>() != 0) continue;
    const auto path = (dir / "train" / "images" / image_file_name(i)).string();
    auto image = read_png(path);
    const auto mask = split.masks[i].contiguous();
    const uint8_t* m = mask.data_ptr<uint8_t>();
    for (int y = 0; y < image.height; ++y)
      for (int x = 0; x < image.width; ++x)
        if (m[y * image.width + x] > 127)
          for (int c = 0; c < 3; ++c) image.pixel(x, y)[c] = static_cast<uint8_t>(image.pixel(x, y)[c] * scale);
    write_png(path, image);
  }
  return dir.string();
}

}  // namespace fskin::testing

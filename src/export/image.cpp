#include "fskin/export/image.h"

#include <stb/stb_image_write.h>

#include <cstring>

#include "fskin/core/error.h"
#include "fskin/util/atomic_file.h"

namespace fskin {

Image::Image(int width, int height, Rgb8 fill) : width(width), height(height) {
  FSKIN_CHECK(width > 0 && height > 0, "image size must be positive, got {}x{}", width, height);
  rgb.resize(3 * static_cast<size_t>(width) * height);
  for (size_t i = 0; i < rgb.size(); i += 3) std::memcpy(&rgb[i], fill.data(), 3);
}

void Image::paste(const Image& tile, int x, int y) {
  FSKIN_CHECK(x >= 0 && y >= 0 && x + tile.width <= width && y + tile.height <= height,
              "image tile {}x{} at ({}, {}) does not fit into {}x{}", tile.width, tile.height, x,
              y, width, height);
  for (int row = 0; row < tile.height; ++row)
    std::memcpy(pixel(x, y + row), tile.pixel(0, row), 3 * static_cast<size_t>(tile.width));
}

void write_png(const std::string& path, const Image& image) {
  FSKIN_CHECK(image.width > 0 && image.height > 0 &&
                  image.rgb.size() == 3 * static_cast<size_t>(image.width) * image.height,
              "{}: cannot write an empty or inconsistent {}x{} image", path, image.width,
              image.height);
  // Encode into memory first so the file itself goes through the atomic writer.
  std::string bytes;
  const auto append = [](void* context, void* data, int size) {
    static_cast<std::string*>(context)->append(static_cast<const char*>(data), size);
  };
  const int ok = stbi_write_png_to_func(append, &bytes, image.width, image.height, 3,
                                        image.rgb.data(), 3 * image.width);
  FSKIN_CHECK(ok != 0, "{}: PNG encoding failed", path);
  write_file_atomically(path, bytes);
}

}  // namespace fskin

#include "fskin/export/image.h"

#include <stb/stb_image.h>
#include <stb/stb_image_write.h>

#include <algorithm>
#include <cctype>
#include <cstring>
#include <filesystem>
#include <memory>

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

namespace {

// fskin writes PNG only: a file named .jpg holding PNG bytes misleads every
// viewer and tool that trusts extensions.
void check_png_name(const std::string& path) {
  auto extension = std::filesystem::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(), [](unsigned char c) { return std::tolower(c); });
  FSKIN_CHECK(extension == ".png", "{}: fskin writes PNG images; name the file .png (not '{}')", path, extension);
}

}  // namespace

void write_png(const std::string& path, const Image& image) {
  check_png_name(path);
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

void write_png_gray(const std::string& path, int width, int height, const std::vector<uint8_t>& gray) {
  check_png_name(path);
  FSKIN_CHECK(width > 0 && height > 0 && gray.size() == static_cast<size_t>(width) * height,
              "{}: cannot write an empty or inconsistent {}x{} grey image", path, width, height);
  std::string bytes;
  const auto append = [](void* context, void* data, int size) {
    static_cast<std::string*>(context)->append(static_cast<const char*>(data), size);
  };
  const int ok = stbi_write_png_to_func(append, &bytes, width, height, 1, gray.data(), width);
  FSKIN_CHECK(ok != 0, "{}: PNG encoding failed", path);
  write_file_atomically(path, bytes);
}

namespace {

// The file's pixels with `channels` channels per pixel (stb converts).
std::vector<uint8_t> decode_png(const std::string& path, int channels, int& width, int& height) {
  const std::string bytes = read_file(path);
  int stored_channels = 0;
  // The header first: a corrupt size must not become a giant allocation.
  FSKIN_CHECK(stbi_info_from_memory(reinterpret_cast<const stbi_uc*>(bytes.data()), static_cast<int>(bytes.size()),
                                    &width, &height, &stored_channels) != 0,
              "{}: not a readable PNG image ({})", path, stbi_failure_reason());
  FSKIN_CHECK(width >= 1 && height >= 1 && width <= kMaxImageSide && height <= kMaxImageSide,
              "{}: {}x{} pixels: each side must be within 1..{}", path, width, height, kMaxImageSide);
  std::unique_ptr<stbi_uc, void (*)(void*)> pixels(
      stbi_load_from_memory(reinterpret_cast<const stbi_uc*>(bytes.data()), static_cast<int>(bytes.size()),
                            &width, &height, &stored_channels, channels),
      stbi_image_free);
  FSKIN_CHECK(pixels != nullptr, "{}: not a readable PNG image ({})", path, stbi_failure_reason());
  FSKIN_CHECK(!stbi_is_16_bit_from_memory(reinterpret_cast<const stbi_uc*>(bytes.data()),
                                          static_cast<int>(bytes.size())),
              "{}: 16-bit PNGs are not supported; store 8 bits per channel", path);
  return {pixels.get(), pixels.get() + static_cast<size_t>(width) * height * channels};
}

}  // namespace

Image read_png(const std::string& path) {
  Image image;
  image.rgb = decode_png(path, 3, image.width, image.height);
  return image;
}

std::vector<uint8_t> read_png_gray(const std::string& path, int& width, int& height) {
  // The first channel, not stb's luminance: masks saved as RGB are equal in all three.
  const auto rgb = decode_png(path, 3, width, height);
  std::vector<uint8_t> gray(static_cast<size_t>(width) * height);
  for (size_t i = 0; i < gray.size(); ++i) gray[i] = rgb[3 * i];
  return gray;
}

}  // namespace fskin

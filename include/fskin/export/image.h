#pragma once
// An 8-bit RGB picture in memory and its PNG file.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace fskin {

using Rgb8 = std::array<uint8_t, 3>;

struct Image {
  int width = 0;
  int height = 0;
  std::vector<uint8_t> rgb;  // row-major, top row first, 3 bytes per pixel

  Image() = default;
  Image(int width, int height, Rgb8 fill = {0, 0, 0});

  uint8_t* pixel(int x, int y) { return rgb.data() + 3 * (static_cast<size_t>(y) * width + x); }
  const uint8_t* pixel(int x, int y) const {
    return rgb.data() + 3 * (static_cast<size_t>(y) * width + x);
  }
  // Copies `tile` with its top-left corner at (x, y); it must fit inside.
  void paste(const Image& tile, int x, int y);
};

// Writes `image` as PNG, atomically; throws fskin::Error naming `path` on failure.
void write_png(const std::string& path, const Image& image);
// Writes width x height 8-bit grey values (row-major, top row first) as a PNG.
void write_png_gray(const std::string& path, int width, int height, const std::vector<uint8_t>& gray);

// The largest image side fskin reads (pixels): beyond it a header is corrupt
// (16384 x 16384 RGB is already 768 MiB).
constexpr int kMaxImageSide = 16384;

// Reads an 8-bit PNG (grey, grey + alpha, RGB or RGBA) as RGB, alpha dropped;
// throws fskin::Error naming `path` when it is missing, not such a PNG, or
// larger than kMaxImageSide on a side.
Image read_png(const std::string& path);
// Reads a PNG as 8-bit grey values (the first channel of a colour PNG);
// sets width and height.
std::vector<uint8_t> read_png_gray(const std::string& path, int& width, int& height);

}  // namespace fskin

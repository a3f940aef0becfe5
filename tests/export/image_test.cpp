#include "fskin/export/image.h"

#include <gtest/gtest.h>
#include <stb/stb_image.h>

#include <filesystem>

#include "fskin/core/error.h"
#include "fskin/util/atomic_file.h"
#include "test_util.h"

namespace fskin {
namespace {

namespace fs = std::filesystem;

TEST(Image, PngRoundTripKeepsSizeAndPixels) {
  Image image(7, 5, {10, 20, 30});
  image.pixel(6, 4)[0] = 255;
  image.pixel(0, 1)[2] = 0;
  Image tile(2, 2, {1, 2, 3});
  image.paste(tile, 3, 2);
  const auto dir = testing::temp_dir("png");
  const auto path = (dir / "nested" / "picture.png").string();
  write_png(path, image);

  int width = 0, height = 0, channels = 0;
  unsigned char* pixels = stbi_load(path.c_str(), &width, &height, &channels, 3);
  ASSERT_NE(pixels, nullptr) << stbi_failure_reason();
  EXPECT_EQ(width, 7);
  EXPECT_EQ(height, 5);
  EXPECT_EQ(channels, 3);
  EXPECT_EQ(std::vector<uint8_t>(pixels, pixels + 7 * 5 * 3), image.rgb);
  EXPECT_EQ(image.pixel(4, 3)[1], 2);
  stbi_image_free(pixels);
  for (const auto& entry : fs::directory_iterator(dir / "nested"))  // no temporary files left
    EXPECT_EQ(entry.path().filename().string(), "picture.png");
  fs::remove_all(dir);
}

TEST(Image, BadSizesThrow) {
  EXPECT_THROW(Image(0, 4), Error);
  EXPECT_THROW(Image(4, -1), Error);
  Image image(4, 4);
  EXPECT_THROW(image.paste(Image(2, 2), 3, 0), Error);
  testing::expect_error([] { write_png("unused.png", Image{}); }, {"unused.png", "empty"});
}

TEST(Image, ReadingRefusesCorruptFilesAndHugeHeadersNamingTheFile) {
  const auto dir = testing::temp_dir("png_bad");
  const auto path = (dir / "mask.png").string();
  write_png(path, Image(6, 4, {200, 0, 0}));
  EXPECT_EQ(read_png(path).width, 6);
  int width = 0, height = 0;
  EXPECT_EQ(read_png_gray(path, width, height)[0], 200);
  // IHDR's width (big-endian, bytes 16..19) set to 100,000: stb would allocate it.
  std::string bytes = read_file(path);
  bytes[16] = 0, bytes[17] = 0x01, bytes[18] = static_cast<char>(0x86), bytes[19] = static_cast<char>(0xa0);
  write_file_atomically(path, bytes);
  testing::expect_error([&] { read_png(path); }, {path, "100000x4", "1..16384"});
  write_file_atomically(path, "not a png");
  testing::expect_error([&] { read_png_gray(path, width, height); }, {path, "not a readable PNG"});
  fs::remove_all(dir);
}

}  // namespace
}  // namespace fskin

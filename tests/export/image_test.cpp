#include "fskin/export/image.h"

#include <gtest/gtest.h>
#include <stb/stb_image.h>

#include <filesystem>

#include "fskin/core/error.h"
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

}  // namespace
}  // namespace fskin

// The headless GL context renders and reads back without a display; PNG round trip and comparison.
#include <gtest/gtest.h>

#include <GL/gl.h>

#include <cstdlib>
#include <filesystem>

#include "core/config.h"
#include "ui/headless_gl.h"
#include "ui/image_io.h"

namespace dd::ui {

TEST(HeadlessGL, ClearsAndReadsBackTopDown) {
  unsetenv("DISPLAY");
  std::string error;
  auto gl = HeadlessGL::create(32, 16, &error);
  ASSERT_TRUE(gl) << error;
  glClearColor(0.f, 0.f, 1.f, 1.f);
  glClear(GL_COLOR_BUFFER_BIT);
  // Paint the top four rows red with a scissored clear (GL's y runs bottom-up).
  glEnable(GL_SCISSOR_TEST);
  glScissor(0, 12, 32, 4);
  glClearColor(1.f, 0.f, 0.f, 1.f);
  glClear(GL_COLOR_BUFFER_BIT);
  glDisable(GL_SCISSOR_TEST);
  const std::vector<uint8_t> px = gl->read_rgba();
  ASSERT_EQ(px.size(), 32u * 16u * 4u);
  EXPECT_EQ(px[0], 255);                    // top-left is red
  EXPECT_EQ(px[2], 0);
  const size_t bottom = (15u * 32u) * 4u;   // bottom-left is blue
  EXPECT_EQ(px[bottom + 0], 0);
  EXPECT_EQ(px[bottom + 2], 255);
}

TEST(ImageIo, PngRoundTripAndCompare) {
  Image img;
  img.width = 4;
  img.height = 3;
  for (int i = 0; i < 12; ++i) img.rgba.insert(img.rgba.end(), {uint8_t(i * 20), 10, 200, 255});
  const auto path = (std::filesystem::temp_directory_path() / "dd_image_io.png").string();
  write_png(path, img);
  const Image back = read_png(path);
  EXPECT_EQ(back.rgba, img.rgba);
  Image changed = img;
  changed.rgba[4 * 5] = uint8_t(changed.rgba[4 * 5] + 30);
  EXPECT_EQ(compare(img, changed, 8).differing, 1);
  EXPECT_EQ(compare(img, changed, 40).differing, 0);
  EXPECT_THROW(read_png(path + ".missing"), Error);
  EXPECT_THROW(write_png("/nonexistent-dir/x.png", img), Error);
  std::filesystem::remove(path);
}

}  // namespace dd::ui

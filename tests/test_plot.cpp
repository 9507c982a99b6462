// Report plots: bars scale to their values, labels fit, fields colour finite cells and grey out the rest.
#include <gtest/gtest.h>

#include <cmath>

#include "ui/plot.h"

namespace dd::ui {
namespace {

// Counts pixels close to an RGB colour.
int count_color(const Image& img, Rgb c, int tol = 10) {
  int n = 0;
  for (size_t p = 0; p < img.rgba.size(); p += 4)
    n += std::abs(img.rgba[p] - c[0]) <= tol && std::abs(img.rgba[p + 1] - c[1]) <= tol && std::abs(img.rgba[p + 2] - c[2]) <= tol;
  return n;
}

}  // namespace

TEST(Plot, BarAreasFollowTheValues) {
  BarPanel p;
  p.title = "t";
  p.y_label = "y";
  p.categories = {"a", "b"};
  p.values = {1.0, 3.0};
  p.errors = {0.0, 0.0};
  p.colors = {{255, 0, 0}, {0, 0, 255}};
  const Image img = draw_bars(p);
  EXPECT_EQ(img.width, p.width);
  EXPECT_EQ(img.height, p.height);
  const int red = count_color(img, {255, 0, 0}), blue = count_color(img, {0, 0, 255});
  ASSERT_GT(red, 100);
  EXPECT_NEAR(static_cast<double>(blue) / red, 3.0, 0.3);
}

TEST(Plot, FieldGreysOutBlockedCellsAndStacks) {
  FieldPanel f;
  f.values = Mat::Constant(4, 4, 1.0f);
  f.values(0, 0) = 2.0f;
  f.values(3, 3) = NAN;
  const Image img = draw_field(f);
  EXPECT_GT(count_color(img, {120, 120, 120}, 2), 100);  // the blocked cell
  const Image both = hstack({img, img}, "caption");
  EXPECT_EQ(both.width, 2 * img.width);
  const Image captioned = hstack({img}, std::string(200, 'x'));  // a caption wider than the panel
  EXPECT_GT(captioned.width, img.width);
  EXPECT_GT(both.height, img.height);
}

}  // namespace dd::ui

// Report plots: bars scale to their values, labels fit, fields colour finite cells and grey out the rest.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

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

// Counts dark (ink) pixels in the rectangle [x0, x1) x [y0, y1).
int count_ink(const Image& img, int x0, int x1, int y0, int y1) {
  int n = 0;
  for (int y = std::max(0, y0); y < std::min(img.height, y1); ++y)
    for (int x = std::max(0, x0); x < std::min(img.width, x1); ++x) {
      const uint8_t* px = &img.rgba[(static_cast<size_t>(y) * img.width + x) * 4];
      n += px[0] < 120 && px[1] < 120 && px[2] < 120;
    }
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

TEST(Plot, AValueNotMeasuredDrawsNoBar) {
  BarPanel p;
  p.title = "t";
  p.y_label = "y";
  p.categories = {"a", "b"};
  p.values = {2.0, NAN};
  p.errors = {0.5, NAN};
  p.colors = {{255, 0, 0}, {0, 0, 255}};
  const Image img = draw_bars(p);
  EXPECT_GT(count_color(img, {255, 0, 0}), 100);  // the measured bar still drawn, to scale
  EXPECT_EQ(count_color(img, {0, 0, 255}), 0);    // none for the value not measured, not a bar of 0
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

TEST(Plot, LinesRiseWhereTheirValuesRise) {
  LinePanel p;
  p.title = "t";
  p.x_label = "x";
  p.y_label = "y";
  p.y_min = 0;
  p.y_max = 1;
  p.series.push_back({"rising", {0, 1, 2}, {0.1, 0.5, 0.9}, {255, 0, 0}});
  p.series.push_back({"flat", {0, 1, 2}, {0.2, 0.2, NAN}, {0, 0, 255}});  // a NaN point is skipped
  const Image img = draw_lines(p);
  EXPECT_EQ(img.width, p.width);
  // the red series' last point (right edge of the plot) sits higher than its first (left edge)
  auto red_row_near = [&](int x0) {
    for (int y = 0; y < img.height; ++y)
      for (int x = x0 - 3; x <= x0 + 3; ++x) {
        const uint8_t* px = &img.rgba[(static_cast<size_t>(y) * img.width + x) * 4];
        if (px[0] > 240 && px[1] < 20 && px[2] < 20) return y;
      }
    return -1;
  };
  const int first_row = red_row_near(80), last_row = red_row_near(p.width - 20);  // the plot area's x range
  ASSERT_GE(first_row, 0);
  ASSERT_GE(last_row, 0);
  EXPECT_LT(last_row, first_row - 100);
  EXPECT_GT(count_color(img, {0, 0, 255}), 20);
  // the legend sits below the plot, one row per series, where it hides no line
  EXPECT_EQ(img.height, p.height + 2 * 18 + 10);
  int legend_red = 0;
  for (int y = p.height; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      const uint8_t* px = &img.rgba[(static_cast<size_t>(y) * img.width + x) * 4];
      legend_red += px[0] > 240 && px[1] < 20 && px[2] < 20;
    }
  EXPECT_GT(legend_red, 10);
}

TEST(Plot, LongBarLabelsBreakAndStayUnderTheirOwnBars) {
  EXPECT_EQ(bar_label_lines("BC", 0.5, 70), std::vector<std::string>{"BC"});
  EXPECT_EQ(bar_label_lines("Ensemble-DAgger", 0.5, 70), (std::vector<std::string>{"Ensemble-", "DAgger"}));
  EXPECT_EQ(bar_label_lines("one two three four", 0.5, 40).size(), 2u);  // never more than two lines
  // figure 4's panels: three method names in 330 pixels (slots of 76 between the 80 and 20 margins)
  BarPanel p;
  p.title = "training";
  p.y_label = "s";
  p.width = 330;
  p.categories = {"Diff-DAgger", "Ensemble-DAgger", "Thrifty-DAgger"};
  p.values = {1, 2, 3};
  const Image img = draw_bars(p);
  const int slot = (p.width - 80 - 20) / 3, band_top = p.height - 60 + 4;
  for (int i = 1; i < 3; ++i)  // no ink where one slot meets the next, under the axis
    EXPECT_EQ(count_ink(img, 80 + slot * i - 1, 80 + slot * i + 2, band_top, img.height), 0) << i;
  for (int i = 0; i < 3; ++i)  // but each label is written, and at least half its slot wide
    EXPECT_GT(count_ink(img, 80 + slot * i + slot / 4, 80 + slot * i + 3 * slot / 4, band_top, img.height), 20) << i;
}

TEST(Plot, TimelineRowNamesAreNotHiddenByTheirSpans) {
  TimelinePanel p;
  p.title = "t";
  p.x_label = "step";
  p.rows = {{"Ensemble-DAgger", {}, {}}, {"Diff-DAgger", {}, {}}};
  const Image bare = draw_timeline(p);
  for (auto& r : p.rows) r.spans = {{0, 100, {255, 0, 0}}};  // red: no ink
  const Image spanned = draw_timeline(p);
  ASSERT_EQ(bare.width, spanned.width);
  // every pixel of the names' ink is still there with the spans drawn beside them
  const int top = 50, rows_end = top + 2 * (34 + 16);
  EXPECT_EQ(count_ink(spanned, 0, spanned.width, top, rows_end), count_ink(bare, 0, bare.width, top, rows_end));
  EXPECT_GT(count_ink(bare, 0, bare.width, top, rows_end), 100);
  EXPECT_GT(timeline_margin_left(p), TimelinePanel::kMarginLeft);  // made room for the longer name
  p.rows = {{"BC", {}, {}}};
  EXPECT_EQ(timeline_margin_left(p), TimelinePanel::kMarginLeft);
}

TEST(Plot, TimelineLegendWrapsInsteadOfRunningOffThePanel) {
  TimelinePanel p;
  p.title = "t";
  p.x_label = "step";
  p.rows = {{"Diff-DAgger", {{0, 10, {60, 110, 210}}}, {5}}};
  // figure 5's legend: five entries and the query mark fit on one line of the 900-pixel panel
  p.legend = {{"robot", {60, 110, 210}}, {"expert (query)", {235, 120, 50}}, {"expert (time limit)", {200, 60, 60}},
              {"demonstration", {80, 160, 90}}, {"operator", {150, 90, 190}}};
  const Image one_line = draw_timeline(p);
  // a sixth entry does not: the legend takes a second line, and nothing is drawn in the right margin
  p.legend.push_back({"expert, then gave up", {120, 72, 40}});
  const Image two_lines = draw_timeline(p);
  EXPECT_GT(two_lines.height, one_line.height);
  const int legend_top = one_line.height - 30;
  EXPECT_EQ(count_ink(two_lines, two_lines.width - TimelinePanel::kMarginRight + 4, two_lines.width, legend_top, two_lines.height), 0);
  EXPECT_GT(count_ink(two_lines, 0, two_lines.width, one_line.height, two_lines.height), 20) << "the second line is written";
  EXPECT_EQ(count_ink(one_line, one_line.width - TimelinePanel::kMarginRight + 4, one_line.width, legend_top, one_line.height), 0);
}

}  // namespace dd::ui

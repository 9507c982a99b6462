// Static figures for reports (PNG): bar charts with error bars and scalar fields over the plane.
// Drawn with OpenCV, no GL; for live plots see the console.
#pragma once

#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "core/types.h"
#include "ui/image_io.h"

namespace dd::ui {

using Rgb = std::array<uint8_t, 3>;

/// A bar chart: one bar per category with a +-err whisker.
struct BarPanel {
  std::string title;
  std::string y_label;              // with units
  std::vector<std::string> categories;
  std::vector<double> values, errors;  // a value that is not finite: not measured, no bar, "-" over its place
  std::vector<Rgb> colors;          // one per bar (cycled)
  int width = 520, height = 420;
};
Image draw_bars(const BarPanel& panel);
/// How draw_bars writes a category under its bar: whole when it fits `max_width` pixels at `scale`,
/// else broken after spaces and hyphens into at most two lines ("Ensemble-" / "DAgger").
std::vector<std::string> bar_label_lines(const std::string& label, double scale, int max_width);

/// A line chart: one polyline with markers per series, a legend, and an optional fixed y range.
struct LineSeries {
  std::string name;
  std::vector<double> x, y;
  Rgb color{60, 110, 210};
  bool markers = true;              // a dot at every point
};
struct LinePanel {
  std::string title;
  std::string x_label, y_label;
  std::vector<LineSeries> series;
  double y_min = NAN, y_max = NAN;  // NaN: from the data
  double x_min = NAN, x_max = NAN;  // both set: exactly this range (to line up with another panel)
  int margin_left = 80, margin_right = 20;
  int width = 560, height = 420;
};
Image draw_lines(const LinePanel& panel);

/// A polyline or a circle drawn over a field, in world coordinates.
struct Overlay {
  std::vector<Eigen::Vector2d> points;  // a polyline when size() > 1
  Eigen::Vector2d center{0, 0};         // a circle when points is empty
  double radius = 0;
  Rgb color{255, 255, 255};
  int thickness = 2;                    // -1 fills a circle
  std::string label;                    // drawn beside the circle / at the polyline's end
};

/// A scalar field over the rectangle [x0, x1] x [y0, y1], drawn as a heat map with a colour bar.
struct FieldPanel {
  std::string title;
  std::string colorbar_label;
  Mat values;                       // rows = y cells (bottom row first), cols = x cells; NaN = blocked
  double x0 = -1, x1 = 1, y0 = -1, y1 = 1;
  bool log_scale = false;
  std::vector<Overlay> overlays;
  int size = 520;                   // side of the square map in pixels
};
Image draw_field(const FieldPanel& panel);

/// Places images side by side on white, top-aligned, with an optional caption line underneath.
Image hstack(const std::vector<Image>& images, const std::string& caption = "");
/// Panels one above the other, left-aligned.
Image vstack(const std::vector<Image>& images);

/// Who acted when: one row per name, coloured spans over a shared x axis (steps), with tick marks
/// (queries) above a row's spans, and a legend of the colours below.
struct TimelineSpan {
  double start = 0, end = 0;
  Rgb color{};
};
struct TimelineRow {
  std::string name;
  std::vector<TimelineSpan> spans;
  std::vector<double> marks;
};
struct TimelinePanel {
  std::string title, x_label, mark_label = "query";
  std::vector<TimelineRow> rows;
  std::vector<std::pair<std::string, Rgb>> legend;
  double x_max = NAN;               // NaN: the data's end, rounded up to a tick
  int width = 900;
  static constexpr int kMarginLeft = 110, kMarginRight = 30;  // at least; wider for long row names
};
/// The x of the panel's time axis' origin: kMarginLeft, or more where a row's name needs it (to line
/// another panel up with the timeline).
int timeline_margin_left(const TimelinePanel& panel);
Image draw_timeline(const TimelinePanel& panel);

}  // namespace dd::ui

#include "ui/plot.h"

#include <fmt/format.h>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace dd::ui {
namespace {

const cv::Scalar kInk(40, 40, 40);
const cv::Scalar kGrid(225, 225, 225);
constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;

cv::Scalar scalar(const Rgb& c) { return cv::Scalar(c[0], c[1], c[2]); }  // canvases are RGB

void text(cv::Mat& m, const std::string& s, cv::Point at, double scale = 0.5, cv::Scalar color = kInk,
          int thickness = 1, bool centered = false) {
  if (centered) {
    int base = 0;
    const cv::Size sz = cv::getTextSize(s, kFont, scale, thickness, &base);
    at.x -= sz.width / 2;
  }
  cv::putText(m, s, at, kFont, scale, color, thickness, cv::LINE_AA);
}

int text_width(const std::string& s, double scale) {
  int base = 0;
  return cv::getTextSize(s, kFont, scale, 1, &base).width;
}

// The band at the left edge that a vertical axis label (vertical_text at x = 16) takes.
constexpr int kAxisLabelBand = 28;

void vertical_text(cv::Mat& m, const std::string& s, cv::Point center, double scale = 0.5) {
  int base = 0;
  const cv::Size sz = cv::getTextSize(s, kFont, scale, 1, &base);
  cv::Mat strip(sz.height + base + 4, sz.width + 4, m.type(), cv::Scalar(255, 255, 255));
  cv::putText(strip, s, {2, sz.height + 1}, kFont, scale, kInk, 1, cv::LINE_AA);
  cv::Mat rotated;
  cv::rotate(strip, rotated, cv::ROTATE_90_COUNTERCLOCKWISE);
  const int x = std::clamp(center.x - rotated.cols / 2, 0, m.cols - rotated.cols);
  const int y = std::clamp(center.y - rotated.rows / 2, 0, m.rows - rotated.rows);
  rotated.copyTo(m(cv::Rect(x, y, rotated.cols, rotated.rows)));
}

std::string fmt_num(double v) {
  char b[32];
  const double a = std::abs(v);
  if (a == 0) return "0";
  if (a != 0 && (a < 1e-2 || a >= 1e4)) std::snprintf(b, sizeof b, "%.1e", v);
  else if (a < 1) std::snprintf(b, sizeof b, "%.3f", v);
  else if (a < 10) std::snprintf(b, sizeof b, "%.2f", v);
  else if (a < 100) std::snprintf(b, sizeof b, "%.1f", v);
  else std::snprintf(b, sizeof b, "%.0f", v);
  return b;
}

// A "nice" step for about n ticks over [0, hi].
double nice_step(double hi, int n) {
  const double raw = hi / n;
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  for (double f : {1.0, 2.0, 2.5, 5.0, 10.0})
    if (f * mag >= raw) return f * mag;
  return 10 * mag;
}

Image to_image(const cv::Mat& rgb) {
  cv::Mat rgba;
  cv::cvtColor(rgb, rgba, cv::COLOR_RGB2RGBA);
  Image img;
  img.width = rgba.cols;
  img.height = rgba.rows;
  img.rgba.assign(rgba.data, rgba.data + rgba.total() * 4);
  return img;
}

cv::Mat to_mat(const Image& img) {
  cv::Mat rgba(img.height, img.width, CV_8UC4, const_cast<uint8_t*>(img.rgba.data()));
  cv::Mat rgb;
  cv::cvtColor(rgba, rgb, cv::COLOR_RGBA2RGB);
  return rgb;
}

}  // namespace

std::vector<std::string> bar_label_lines(const std::string& label, double scale, int max_width) {
  if (text_width(label, scale) <= max_width) return {label};
  // the pieces a line may break after: a space (dropped) or a hyphen (kept)
  std::vector<std::string> pieces;
  std::string piece;
  for (char c : label) {
    if (c == ' ') {
      if (!piece.empty()) pieces.push_back(piece);
      piece.clear();
      continue;
    }
    piece += c;
    if (c == '-') pieces.push_back(piece), piece.clear();
  }
  if (!piece.empty()) pieces.push_back(piece);
  // a line and the next piece: a space between them unless the line ends in its hyphen
  auto join = [](const std::string& line, const std::string& next) { return line + (line.back() == '-' ? "" : " ") + next; };
  std::vector<std::string> lines;
  for (const std::string& w : pieces) {
    if (!lines.empty() && text_width(join(lines.back(), w), scale) <= max_width) lines.back() = join(lines.back(), w);
    else lines.push_back(w);
  }
  if (lines.size() <= 2) return lines;
  // at most two lines under a bar: the rest joins the second
  std::string rest = lines[1];
  for (size_t k = 2; k < lines.size(); ++k) rest = join(rest, lines[k]);
  return {lines[0], rest};
}

Image draw_bars(const BarPanel& p) {
  cv::Mat m(p.height, p.width, CV_8UC3, cv::Scalar(255, 255, 255));
  const int left = 80, right = 20, top = 50, bottom = 60;
  const cv::Rect area(left, top, p.width - left - right, p.height - top - bottom);
  double hi = 0;
  for (size_t i = 0; i < p.values.size(); ++i) {
    const double e = i < p.errors.size() ? p.errors[i] : 0;
    if (std::isfinite(p.values[i] + e)) hi = std::max(hi, p.values[i] + e);
  }
  if (hi <= 0) hi = 1;
  hi *= 1.12;  // headroom for the value labels above the bars
  const double step = nice_step(hi, 5);
  hi = std::ceil(hi / step) * step;
  auto y_of = [&](double v) { return area.y + area.height - static_cast<int>(std::lround(v / hi * area.height)); };
  for (double v = 0; v <= hi + 1e-12; v += step) {
    const int y = y_of(v);
    cv::line(m, {area.x, y}, {area.x + area.width, y}, kGrid, 1);
    text(m, fmt_num(v), {area.x - 8 - 8 * static_cast<int>(fmt_num(v).size()), y + 4}, 0.42);
  }
  const int n = static_cast<int>(p.values.size());
  const int slot = n ? area.width / n : area.width;
  // Each category under its bar, broken into lines where it does not fit its slot, all at the one
  // scale at which the widest line fits.
  const int fit = slot - 6;
  std::vector<std::vector<std::string>> labels;
  double label_scale = 0.5;
  for (const std::string& c : p.categories) labels.push_back(bar_label_lines(c, 0.5, fit));
  for (const auto& lines : labels)
    for (const std::string& l : lines)
      while (label_scale > 0.3 && text_width(l, label_scale) > fit) label_scale -= 0.02;
  for (int i = 0; i < n; ++i) {
    const int cx = area.x + slot * i + slot / 2, half = slot * 3 / 10;
    const bool measured = std::isfinite(p.values[i]);
    const double v = measured ? p.values[i] : 0;
    const Rgb color = p.colors.empty() ? Rgb{90, 120, 200} : p.colors[static_cast<size_t>(i) % p.colors.size()];
    if (measured) {
      cv::rectangle(m, {cx - half, y_of(v)}, {cx + half, y_of(0)}, scalar(color), cv::FILLED);
      cv::rectangle(m, {cx - half, y_of(v)}, {cx + half, y_of(0)}, kInk, 1);
    }
    // an unmeasured bar has no whisker, and its "-" sits on the axis
    const double err = measured && static_cast<size_t>(i) < p.errors.size() && std::isfinite(p.errors[i]) ? p.errors[i] : 0.0;
    if (err > 0) {
      const int y0 = y_of(std::max(0.0, v - err)), y1 = y_of(v + err);
      cv::line(m, {cx, y0}, {cx, y1}, kInk, 2);
      cv::line(m, {cx - 8, y0}, {cx + 8, y0}, kInk, 2);
      cv::line(m, {cx - 8, y1}, {cx + 8, y1}, kInk, 2);
    }
    text(m, measured ? fmt_num(v) : "-", {cx, y_of(v + err) - 8}, 0.42, kInk, 1, true);
    if (static_cast<size_t>(i) < labels.size())
      for (size_t k = 0; k < labels[static_cast<size_t>(i)].size(); ++k)
        text(m, labels[static_cast<size_t>(i)][k], {cx, area.y + area.height + 22 + 16 * static_cast<int>(k)}, label_scale, kInk, 1, true);
  }
  cv::line(m, {area.x, area.y}, {area.x, area.y + area.height}, kInk, 1);
  cv::line(m, {area.x, area.y + area.height}, {area.x + area.width, area.y + area.height}, kInk, 1);
  text(m, p.title, {p.width / 2, 30}, 0.62, kInk, 2, true);
  vertical_text(m, p.y_label, {16, area.y + area.height / 2});
  return to_image(m);
}

Image draw_lines(const LinePanel& p) {
  // the legend goes below the plot, a row per named series, so it never hides a line
  const int named = static_cast<int>(std::count_if(p.series.begin(), p.series.end(), [](const LineSeries& s) { return !s.name.empty(); }));
  const int legend_h = named > 0 ? 18 * named + 10 : 0;
  cv::Mat m(p.height + legend_h, p.width, CV_8UC3, cv::Scalar(255, 255, 255));
  double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
  for (const auto& s : p.series)
    for (size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
      x0 = std::min(x0, s.x[i]), x1 = std::max(x1, s.x[i]);
      y0 = std::min(y0, s.y[i]), y1 = std::max(y1, s.y[i]);
    }
  if (!std::isfinite(x0)) x0 = 0, x1 = 1, y0 = 0, y1 = 1;
  if (std::isfinite(p.y_min)) y0 = p.y_min;
  if (std::isfinite(p.y_max)) y1 = p.y_max;
  if (!(x1 > x0)) {  // one x value (e.g. one demonstration count): centre it in a readable span
    const double half = std::max(1.0, std::abs(x0) / 2);
    x0 -= half, x1 += half;
  }
  if (!(y1 > y0)) y1 = y0 + 1;
  const bool fixed_x = std::isfinite(p.x_min) && std::isfinite(p.x_max) && p.x_max > p.x_min;
  if (fixed_x) x0 = p.x_min, x1 = p.x_max;
  const double xstep = nice_step(x1 - x0, fixed_x ? 8 : 6), ystep = nice_step(y1 - y0, 5);
  if (!fixed_x) x0 = std::floor(x0 / xstep) * xstep, x1 = std::ceil(x1 / xstep) * xstep;
  // the left margin holds the widest y tick label, right-aligned, clear of the vertical axis label
  std::vector<std::pair<double, std::string>> y_ticks;
  int label_w = 0;
  for (double v = std::ceil(y0 / ystep) * ystep; v <= y1 + 1e-12; v += ystep) {
    y_ticks.emplace_back(v, fmt_num(v));
    label_w = std::max(label_w, text_width(y_ticks.back().second, 0.42));
  }
  const int left = std::max(p.margin_left, kAxisLabelBand + label_w + 8), right = p.margin_right, top = 50, bottom = 60;
  const cv::Rect area(left, top, p.width - left - right, p.height - top - bottom);
  auto px = [&](double x, double y) {
    return cv::Point(area.x + static_cast<int>(std::lround((x - x0) / (x1 - x0) * area.width)),
                     area.y + area.height - static_cast<int>(std::lround((y - y0) / (y1 - y0) * area.height)));
  };
  for (const auto& [v, label] : y_ticks) {
    const int y = px(x0, v).y;
    cv::line(m, {area.x, y}, {area.x + area.width, y}, kGrid, 1);
    text(m, label, {area.x - 8 - text_width(label, 0.42), y + 4}, 0.42);
  }
  for (double v = x0; v <= x1 + 1e-12; v += xstep) {
    const int x = px(v, y0).x;
    cv::line(m, {x, area.y}, {x, area.y + area.height}, kGrid, 1);
    char b[32];
    std::snprintf(b, sizeof b, "%g", v);
    text(m, b, {x, area.y + area.height + 18}, 0.42, kInk, 1, true);
  }
  for (const auto& s : p.series) {
    std::vector<cv::Point> pts;
    for (size_t i = 0; i < s.x.size() && i < s.y.size(); ++i)
      if (std::isfinite(s.x[i]) && std::isfinite(s.y[i])) pts.push_back(px(s.x[i], s.y[i]));
    if (pts.size() > 1) cv::polylines(m, pts, false, scalar(s.color), 2, cv::LINE_AA);
    if (s.markers)
      for (const auto& q : pts) cv::circle(m, q, 4, scalar(s.color), cv::FILLED, cv::LINE_AA);
  }
  // legend, below the x axis label
  int ly = p.height + 10;
  for (const auto& s : p.series) {
    if (s.name.empty()) continue;
    cv::line(m, {area.x + 10, ly - 4}, {area.x + 30, ly - 4}, scalar(s.color), 2, cv::LINE_AA);
    if (s.markers) cv::circle(m, {area.x + 20, ly - 4}, 4, scalar(s.color), cv::FILLED, cv::LINE_AA);
    text(m, s.name, {area.x + 36, ly}, 0.42);
    ly += 18;
  }
  cv::line(m, {area.x, area.y}, {area.x, area.y + area.height}, kInk, 1);
  cv::line(m, {area.x, area.y + area.height}, {area.x + area.width, area.y + area.height}, kInk, 1);
  text(m, p.title, {p.width / 2, 30}, 0.62, kInk, 2, true);
  text(m, p.x_label, {area.x + area.width / 2, p.height - 14}, 0.5, kInk, 1, true);
  vertical_text(m, p.y_label, {16, area.y + area.height / 2});
  return to_image(m);
}

Image draw_field(const FieldPanel& p) {
  const int map = p.size, bar_w = 18, pad_l = 20, pad_r = 110, top = 50, bottom = 30;
  cv::Mat m(top + map + bottom, pad_l + map + pad_r, CV_8UC3, cv::Scalar(255, 255, 255));
  // Value range over finite cells.
  double lo = INFINITY, hi = -INFINITY;
  for (Eigen::Index i = 0; i < p.values.size(); ++i) {
    double v = p.values.data()[i];
    if (!std::isfinite(v) || (p.log_scale && v <= 0)) continue;
    v = p.log_scale ? std::log10(v) : v;
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  if (!(hi > lo)) hi = lo + 1;
  cv::Mat gray(static_cast<int>(p.values.rows()), static_cast<int>(p.values.cols()), CV_8UC1);
  cv::Mat blocked(gray.size(), CV_8UC1, cv::Scalar(0));
  for (int r = 0; r < gray.rows; ++r) {
    for (int c = 0; c < gray.cols; ++c) {
      double v = p.values(gray.rows - 1 - r, c);  // image rows run top-down, field rows bottom-up
      const bool ok = std::isfinite(v) && (!p.log_scale || v > 0);
      blocked.at<uint8_t>(r, c) = ok ? 0 : 255;
      v = ok ? (p.log_scale ? std::log10(v) : v) : lo;
      gray.at<uint8_t>(r, c) = static_cast<uint8_t>(std::clamp((v - lo) / (hi - lo), 0.0, 1.0) * 255);
    }
  }
  cv::Mat big_gray, big_blocked, colored;
  cv::resize(gray, big_gray, {map, map}, 0, 0, cv::INTER_NEAREST);
  cv::resize(blocked, big_blocked, {map, map}, 0, 0, cv::INTER_NEAREST);
  cv::applyColorMap(big_gray, colored, cv::COLORMAP_VIRIDIS);  // BGR
  cv::cvtColor(colored, colored, cv::COLOR_BGR2RGB);
  colored.setTo(cv::Scalar(120, 120, 120), big_blocked);
  colored.copyTo(m(cv::Rect(pad_l, top, map, map)));

  auto px = [&](const Eigen::Vector2d& w) {
    return cv::Point(pad_l + static_cast<int>((w.x() - p.x0) / (p.x1 - p.x0) * map),
                     top + static_cast<int>((p.y1 - w.y()) / (p.y1 - p.y0) * map));
  };
  cv::Mat area = m(cv::Rect(pad_l, top, map, map));
  for (const Overlay& o : p.overlays) {
    if (o.points.size() > 1) {
      std::vector<cv::Point> pts;
      for (const auto& w : o.points) pts.push_back(px(w) - cv::Point(pad_l, top));
      cv::polylines(area, pts, false, scalar(o.color), o.thickness, cv::LINE_AA);
      if (!o.label.empty()) text(m, o.label, px(o.points.back()) + cv::Point(6, 0), 0.45, scalar(o.color), 1);
    } else {
      const int rad = std::max(2, static_cast<int>(o.radius / (p.x1 - p.x0) * map));
      cv::circle(m, px(o.center), rad, scalar(o.color), o.thickness, cv::LINE_AA);
      if (!o.label.empty()) text(m, o.label, px(o.center) + cv::Point(rad + 4, 5), 0.45, scalar(o.color), 1);
    }
  }
  cv::rectangle(m, cv::Rect(pad_l, top, map, map), kInk, 1);

  // Colour bar.
  const int bx = pad_l + map + 14;
  cv::Mat ramp(map, 1, CV_8UC1);
  for (int r = 0; r < map; ++r) ramp.at<uint8_t>(r, 0) = static_cast<uint8_t>(255 - r * 255 / std::max(1, map - 1));
  cv::Mat ramp_c, ramp_big;
  cv::applyColorMap(ramp, ramp_c, cv::COLORMAP_VIRIDIS);
  cv::cvtColor(ramp_c, ramp_c, cv::COLOR_BGR2RGB);
  cv::resize(ramp_c, ramp_big, {bar_w, map}, 0, 0, cv::INTER_NEAREST);
  ramp_big.copyTo(m(cv::Rect(bx, top, bar_w, map)));
  cv::rectangle(m, cv::Rect(bx, top, bar_w, map), kInk, 1);
  for (int k = 0; k <= 4; ++k) {
    const double v = lo + (hi - lo) * k / 4.0;
    const int y = top + map - k * map / 4;
    text(m, fmt_num(p.log_scale ? std::pow(10.0, v) : v), {bx + bar_w + 4, y + 4}, 0.4);
  }
  vertical_text(m, p.colorbar_label + (p.log_scale ? " (log scale)" : ""), {bx + bar_w + 80, top + map / 2}, 0.45);
  text(m, p.title, {pad_l + map / 2, 32}, 0.6, kInk, 2, true);
  return to_image(m);
}

Image hstack(const std::vector<Image>& images, const std::string& caption) {
  int w = 0, h = 0;
  for (const auto& i : images) {
    w += i.width;
    h = std::max(h, i.height);
  }
  const int cap = caption.empty() ? 0 : 34;
  int base = 0;
  const int caption_w = caption.empty() ? 0 : cv::getTextSize(caption, kFont, 0.45, 1, &base).width + 24;
  const int width = std::max({w, caption_w, 1});
  cv::Mat m(h + cap, width, CV_8UC3, cv::Scalar(255, 255, 255));
  int x = (width - w) / 2;  // centre the panels when the caption is wider
  for (const auto& i : images) {
    to_mat(i).copyTo(m(cv::Rect(x, 0, i.width, i.height)));
    x += i.width;
  }
  if (cap) text(m, caption, {m.cols / 2, h + 22}, 0.45, cv::Scalar(90, 90, 90), 1, true);
  return to_image(m);
}

Image vstack(const std::vector<Image>& images) {
  int w = 1, h = 0;
  for (const auto& i : images) {
    w = std::max(w, i.width);
    h += i.height;
  }
  cv::Mat m(std::max(h, 1), w, CV_8UC3, cv::Scalar(255, 255, 255));
  int y = 0;
  for (const auto& i : images) {
    to_mat(i).copyTo(m(cv::Rect(0, y, i.width, i.height)));
    y += i.height;
  }
  return to_image(m);
}

int timeline_margin_left(const TimelinePanel& p) {
  int left = TimelinePanel::kMarginLeft;
  for (const auto& r : p.rows) left = std::max(left, 8 + text_width(r.name, 0.45) + 12);
  return left;
}

Image draw_timeline(const TimelinePanel& p) {
  const int left = timeline_margin_left(p), right = TimelinePanel::kMarginRight, top = 50, row_h = 34, gap = 16, axis_h = 50;
  const int rows = static_cast<int>(p.rows.size());
  // the legend: colour swatches, then the mark, in lines that fit between the margins
  struct Item {
    int x, line;
  };
  std::vector<Item> items;
  int lines = 1;
  {
    int x = left;
    auto place = [&](int w) {
      if (x > left && x + w > p.width - right) x = left, ++lines;
      items.push_back({x, lines - 1});
      x += w + 12;
    };
    for (const auto& entry : p.legend) place(28 + text_width(entry.first, 0.42));
    place(18 + text_width(p.mark_label, 0.42));
  }
  const int legend_line_h = 22, legend_h = 30 + legend_line_h * (lines - 1);
  const int height = top + rows * (row_h + gap) + axis_h + legend_h;
  cv::Mat m(height, p.width, CV_8UC3, cv::Scalar(255, 255, 255));
  double x1 = 1;
  for (const auto& r : p.rows) {
    for (const auto& s : r.spans) x1 = std::max(x1, s.end);
    for (double k : r.marks) x1 = std::max(x1, k);
  }
  const bool fixed_x = std::isfinite(p.x_max) && p.x_max > 0;
  if (fixed_x) x1 = p.x_max;
  const double step = nice_step(x1, 8);
  if (!fixed_x) x1 = std::ceil(x1 / step) * step;
  const int plot_w = p.width - left - right;
  auto x_of = [&](double v) { return left + static_cast<int>(std::lround(v / x1 * plot_w)); };
  const int axis_y = top + rows * (row_h + gap);
  for (double v = 0; v <= x1 + 1e-9; v += step) {
    cv::line(m, {x_of(v), top - 6}, {x_of(v), axis_y}, kGrid, 1);
    text(m, step >= 1 ? fmt::format("{:.0f}", v) : fmt_num(v), {x_of(v), axis_y + 18}, 0.42, kInk, 1, true);
  }
  for (int i = 0; i < rows; ++i) {
    const TimelineRow& r = p.rows[static_cast<size_t>(i)];
    const int y = top + i * (row_h + gap) + 8;
    text(m, r.name, {8, y + row_h / 2 + 5}, 0.45);
    for (const auto& s : r.spans)
      cv::rectangle(m, {x_of(s.start), y}, {std::max(x_of(s.start) + 1, x_of(s.end)), y + row_h}, scalar(s.color), cv::FILLED);
    cv::rectangle(m, {left, y}, {left + plot_w, y + row_h}, kGrid, 1);
    for (double k : r.marks) {  // a downward triangle above the row
      const int x = x_of(k);
      const std::vector<cv::Point> tri{{x - 6, y - 10}, {x + 6, y - 10}, {x, y - 1}};
      cv::fillConvexPoly(m, tri, kInk, cv::LINE_AA);
    }
  }
  cv::line(m, {left, axis_y}, {left + plot_w, axis_y}, kInk, 1);
  text(m, p.x_label, {left + plot_w / 2, axis_y + 40}, 0.45, kInk, 1, true);
  text(m, p.title, {p.width / 2, 28}, 0.62, kInk, 2, true);
  const int ly0 = axis_y + axis_h + 16;
  for (size_t i = 0; i < p.legend.size(); ++i) {
    const int x = items[i].x, ly = ly0 + legend_line_h * items[i].line;
    cv::rectangle(m, {x, ly - 11}, {x + 22, ly + 1}, scalar(p.legend[i].second), cv::FILLED);
    text(m, p.legend[i].first, {x + 28, ly}, 0.42);
  }
  const int x = items.back().x, ly = ly0 + legend_line_h * items.back().line;
  const std::vector<cv::Point> tri{{x, ly - 11}, {x + 12, ly - 11}, {x + 6, ly}};
  cv::fillConvexPoly(m, tri, kInk, cv::LINE_AA);
  text(m, p.mark_label, {x + 18, ly}, 0.42);
  return to_image(m);
}

}  // namespace dd::ui

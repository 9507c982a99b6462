#include "ui/image_io.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cstdlib>

#include "core/config.h"

namespace dd::ui {

void write_png(const std::string& path, const Image& image) {
  cv::Mat rgba(image.height, image.width, CV_8UC4, const_cast<uint8_t*>(image.rgba.data()));
  cv::Mat bgra;
  cv::cvtColor(rgba, bgra, cv::COLOR_RGBA2BGRA);
  bool ok = false;
  try {
    ok = cv::imwrite(path, bgra);
  } catch (const cv::Exception& e) {
    throw Error(path + ": could not write PNG: " + e.what());
  }
  if (!ok) throw Error(path + ": could not write PNG");
}

Image read_png(const std::string& path) {
  const cv::Mat bgra = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (bgra.empty()) throw Error(path + ": missing or not a readable image");
  cv::Mat rgba;
  if (bgra.channels() == 4) cv::cvtColor(bgra, rgba, cv::COLOR_BGRA2RGBA);
  else if (bgra.channels() == 3) cv::cvtColor(bgra, rgba, cv::COLOR_BGR2RGBA);
  else cv::cvtColor(bgra, rgba, cv::COLOR_GRAY2RGBA);
  Image img;
  img.width = rgba.cols;
  img.height = rgba.rows;
  img.rgba.assign(rgba.data, rgba.data + rgba.total() * 4);
  return img;
}

ImageDiff compare(const Image& a, const Image& b, int tolerance) {
  ImageDiff d;
  d.heat = a;
  if (a.width != b.width || a.height != b.height) {
    d.differing = a.width * a.height;
    d.max_delta = 255;
    return d;
  }
  for (size_t p = 0; p < a.rgba.size(); p += 4) {
    int delta = 0;
    for (int c = 0; c < 4; ++c) delta = std::max(delta, std::abs(int(a.rgba[p + c]) - int(b.rgba[p + c])));
    d.max_delta = std::max(d.max_delta, delta);
    for (int c = 0; c < 3; ++c) d.heat.rgba[p + c] = static_cast<uint8_t>(a.rgba[p + c] / 3);
    if (delta > tolerance) {
      ++d.differing;
      d.heat.rgba[p] = 255;
    }
    d.heat.rgba[p + 3] = 255;
  }
  return d;
}

}  // namespace dd::ui

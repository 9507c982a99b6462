// Writing and comparing RGBA images (screenshots, goldens).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace dd::ui {

/// An 8-bit RGBA image, rows top-down.
struct Image {
  int width = 0, height = 0;
  std::vector<uint8_t> rgba;  // width * height * 4
};

/// Writes a PNG. Throws dd::Error naming the file when it cannot be written.
void write_png(const std::string& path, const Image& image);
/// Reads a PNG as RGBA. Throws dd::Error naming the file when it is missing or unreadable.
Image read_png(const std::string& path);

/// How two images of the same size differ: pixels whose any channel differs by more than `tolerance`.
struct ImageDiff {
  int differing = 0;  // pixels beyond tolerance
  int max_delta = 0;  // largest channel difference
  Image heat;         // differing pixels in red over a dimmed copy of `a`
};
/// Compares two images; sizes must match (else differing = all pixels).
ImageDiff compare(const Image& a, const Image& b, int tolerance);

}  // namespace dd::ui

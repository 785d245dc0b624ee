// A PNG in memory as 8-bit RGB pixels (libpng's simplified API).
#pragma once

#include <png.h>

#include <vector>

namespace coopdyn::testing {

struct Image {
  int w = 0, h = 0;
  std::vector<unsigned char> rgb;
  const unsigned char* at(int x, int y) const { return &rgb[3 * (static_cast<size_t>(y) * w + x)]; }
};

inline bool read_png(const std::vector<unsigned char>& bytes, Image* im) {
  png_image p{};
  p.version = PNG_IMAGE_VERSION;
  if (bytes.empty() || !png_image_begin_read_from_memory(&p, bytes.data(), bytes.size())) return false;
  p.format = PNG_FORMAT_RGB;
  im->w = static_cast<int>(p.width);
  im->h = static_cast<int>(p.height);
  im->rgb.resize(PNG_IMAGE_SIZE(p));
  if (!png_image_finish_read(&p, nullptr, im->rgb.data(), 0, nullptr)) {
    png_image_free(&p);
    return false;
  }
  return true;
}

}  // namespace coopdyn::testing

// RGB images for the software renderer: PNG output (stb), text (stb_easy_font),
// colour maps, colour bars and side-by-side panels.
#pragma once
#include <Eigen/Core>
#include <string>
#include <vector>

namespace shapemap {

struct Image {
  int width = 0, height = 0;
  std::vector<float> rgb;  // row-major, 3 floats per pixel in [0,1]
  Image() = default;
  Image(int w, int h, const Eigen::Vector3f& fill = Eigen::Vector3f::Ones());
  Eigen::Map<Eigen::Vector3f> at(int x, int y) { return Eigen::Map<Eigen::Vector3f>(&rgb[3 * (size_t(y) * width + x)]); }
  Eigen::Vector3f at(int x, int y) const {
    const float* p = &rgb[3 * (size_t(y) * width + x)];
    return {p[0], p[1], p[2]};
  }
  void fill_rect(int x0, int y0, int x1, int y1, const Eigen::Vector3f& c);
};

// Writes an 8-bit RGB PNG atomically. Throws Error on failure.
void write_png(const std::string& path, const Image& img);
// The PNG bytes (for embedding into report.html).
std::vector<unsigned char> encode_png(const Image& img);

// Text with the stb_easy_font bitmap font, scaled by an integer factor.
void draw_text(Image& img, int x, int y, const std::string& text, const Eigen::Vector3f& color,
               int scale = 2);
int text_width(const std::string& text, int scale = 2);

// Colour maps: t in [0,1].
Eigen::Vector3f colormap_viridis(double t);
Eigen::Vector3f colormap_diverging(double t);  // blue - white - red

// A vertical colour bar with min/max labels, drawn at (x, y) with the given size.
void draw_colorbar(Image& img, int x, int y, int w, int h, double vmin, double vmax,
                   const std::string& label, bool diverging = false);

// Panels side by side with a caption above each; all panels are padded to the tallest.
Image hconcat(const std::vector<Image>& panels, const std::vector<std::string>& captions);

}  // namespace shapemap

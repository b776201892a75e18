// Images, PNG output, bitmap text, colour maps, colour bars and panels.
#include "shapemap/render/image.h"
#include "shapemap/error.h"
#include "shapemap/io.h"
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>

// Third-party single-header libraries: their own warnings are not ours to fix.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wunused-function"
#define STB_IMAGE_WRITE_IMPLEMENTATION
#define STBI_WRITE_NO_STDIO
#include <stb_image_write.h>
#include <stb_easy_font.h>
#pragma GCC diagnostic pop

namespace shapemap {

Image::Image(int w, int h, const Eigen::Vector3f& fill) : width(w), height(h), rgb(size_t(w) * h * 3) {
  for (size_t i = 0; i < size_t(w) * h; ++i)
    for (int c = 0; c < 3; ++c) rgb[3 * i + c] = fill[c];
}

void Image::fill_rect(int x0, int y0, int x1, int y1, const Eigen::Vector3f& c) {
  x0 = std::max(x0, 0), y0 = std::max(y0, 0);
  x1 = std::min(x1, width), y1 = std::min(y1, height);
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) at(x, y) = c;
}

static void append_bytes(void* ctx, void* data, int size) {
  auto* out = static_cast<std::vector<unsigned char>*>(ctx);
  auto* p = static_cast<unsigned char*>(data);
  out->insert(out->end(), p, p + size);
}

std::vector<unsigned char> encode_png(const Image& img) {
  std::vector<unsigned char> px(size_t(img.width) * img.height * 3);
  for (size_t i = 0; i < px.size(); ++i)
    px[i] = (unsigned char)std::lround(255.0f * std::clamp(img.rgb[i], 0.0f, 1.0f));
  std::vector<unsigned char> out;
  if (!stbi_write_png_to_func(append_bytes, &out, img.width, img.height, 3, px.data(), img.width * 3))
    throw Error("PNG encoding failed");
  return out;
}

void write_png(const std::string& path, const Image& img) {
  std::vector<unsigned char> bytes = encode_png(img);
  write_text_atomic(path, std::string(bytes.begin(), bytes.end()));
}

int text_width(const std::string& text, int scale) {
  std::vector<char> buf(text.begin(), text.end());
  buf.push_back(0);
  return stb_easy_font_width(buf.data()) * scale;
}

void draw_text(Image& img, int x, int y, const std::string& text, const Eigen::Vector3f& color, int scale) {
  std::vector<char> str(text.begin(), text.end());
  str.push_back(0);
  std::vector<char> buffer(std::max<size_t>(1000, text.size() * 300));
  int quads = stb_easy_font_print(0, 0, str.data(), nullptr, buffer.data(), int(buffer.size()));
  struct Vtx {
    float x, y, z;
    unsigned char c[4];
  };
  const Vtx* v = reinterpret_cast<const Vtx*>(buffer.data());
  for (int q = 0; q < quads; ++q) {
    float x0 = v[4 * q].x, y0 = v[4 * q].y, x1 = v[4 * q + 2].x, y1 = v[4 * q + 2].y;
    img.fill_rect(x + int(x0 * scale), y + int(y0 * scale), x + int(x1 * scale), y + int(y1 * scale), color);
  }
}

static Eigen::Vector3f lerp_table(const float (*tab)[3], int n, double t) {
  if (!std::isfinite(t)) return {0.6f, 0.6f, 0.6f};
  t = std::clamp(t, 0.0, 1.0) * (n - 1);
  int i = std::min(int(t), n - 2);
  float s = float(t - i);
  return Eigen::Vector3f(tab[i][0], tab[i][1], tab[i][2]) * (1 - s) +
         Eigen::Vector3f(tab[i + 1][0], tab[i + 1][1], tab[i + 1][2]) * s;
}

Eigen::Vector3f colormap_viridis(double t) {
  // Nine samples of matplotlib's viridis, linearly interpolated.
  static const float tab[9][3] = {{0.267f, 0.005f, 0.329f}, {0.283f, 0.141f, 0.458f}, {0.254f, 0.265f, 0.530f},
                                  {0.207f, 0.372f, 0.553f}, {0.164f, 0.471f, 0.558f}, {0.128f, 0.567f, 0.551f},
                                  {0.135f, 0.659f, 0.518f}, {0.478f, 0.821f, 0.318f}, {0.993f, 0.906f, 0.144f}};
  return lerp_table(tab, 9, t);
}

Eigen::Vector3f colormap_diverging(double t) {
  static const float tab[5][3] = {{0.23f, 0.30f, 0.75f}, {0.55f, 0.69f, 0.99f}, {0.87f, 0.87f, 0.87f},
                                  {0.96f, 0.60f, 0.48f}, {0.71f, 0.02f, 0.15f}};
  return lerp_table(tab, 5, t);
}

static std::string short_number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

void draw_colorbar(Image& img, int x, int y, int w, int h, double vmin, double vmax, const std::string& label,
                   bool diverging) {
  for (int j = 0; j < h; ++j) {
    double t = 1.0 - double(j) / std::max(1, h - 1);
    Eigen::Vector3f c = diverging ? colormap_diverging(t) : colormap_viridis(t);
    img.fill_rect(x, y + j, x + w, y + j + 1, c);
  }
  Eigen::Vector3f black(0, 0, 0);
  draw_text(img, x + w + 4, y, short_number(vmax), black);
  draw_text(img, x + w + 4, y + h - 14, short_number(vmin), black);
  draw_text(img, x, y - 18, label, black);
}

Image hconcat(const std::vector<Image>& panels, const std::vector<std::string>& captions) {
  const int caption_h = 26, gap = 6;
  int W = 0, H = 0;
  for (auto& p : panels) {
    W += p.width + gap;
    H = std::max(H, p.height);
  }
  Image out(std::max(1, W - gap), H + caption_h);
  int x = 0;
  for (size_t i = 0; i < panels.size(); ++i) {
    const Image& p = panels[i];
    for (int yy = 0; yy < p.height; ++yy)
      for (int xx = 0; xx < p.width; ++xx) out.at(x + xx, caption_h + yy) = p.at(xx, yy);
    if (i < captions.size()) {
      int tw = text_width(captions[i]);
      draw_text(out, x + std::max(0, (p.width - tw) / 2), 4, captions[i], Eigen::Vector3f(0, 0, 0));
    }
    x += p.width + gap;
  }
  return out;
}

}  // namespace shapemap

// tool_plot: the scaling plot of the benchmark suite (bench/run calls it at the end).
//
//   tool_plot [RESULTS.json] [-o PNG]      (defaults: bench/results.json, bench/scaling.png)
//
// Reads the "runs" of bench/results.json (written by bench/run through tool_bench_util)
// and draws a log-log PNG of wall time against problem size, one line per method, with
// the least-squares growth exponent k of t ~ c n^k in the legend. Runs are grouped into
// panels by their size measure ("vertices" for surface methods, "tets" for volume
// methods). Failed runs are drawn as crosses on the top edge of their panel at their size.
// Drawn with the project's own image utilities (include/shapemap/render/image.h).
#include "shapemap/render/image.h"
#include <nlohmann/json.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <string>
#include <vector>

using shapemap::Image;
using Color = Eigen::Vector3f;

namespace {

struct Point {
  double x = 0, t = 0;
  bool ok = false;
};

struct Series {
  std::string method;
  std::vector<Point> points;
  double slope = NAN, intercept = NAN;  // log10 t = intercept + slope log10 n
};

// Least squares fit of log10(t) against log10(n) over the successful runs; NAN when
// there are fewer than two distinct sizes.
void fit(Series& s) {
  std::vector<double> lx, lt;
  for (auto& p : s.points)
    if (p.ok && p.x > 0 && p.t > 0) {
      lx.push_back(std::log10(p.x));
      lt.push_back(std::log10(p.t));
    }
  if (lx.size() < 2) return;
  double mx = 0, mt = 0;
  for (size_t i = 0; i < lx.size(); ++i) mx += lx[i], mt += lt[i];
  mx /= lx.size(), mt /= lt.size();
  double sxx = 0, sxt = 0;
  for (size_t i = 0; i < lx.size(); ++i) {
    sxx += (lx[i] - mx) * (lx[i] - mx);
    sxt += (lx[i] - mx) * (lt[i] - mt);
  }
  if (sxx < 1e-12) return;
  s.slope = sxt / sxx;
  s.intercept = mt - s.slope * mx;
}

void put(Image& img, int x, int y, const Color& c) {
  if (x >= 0 && y >= 0 && x < img.width && y < img.height) img.at(x, y) = c;
}

// A line of the given thickness (Bresenham, a square brush); dash > 0 draws dashes.
void line(Image& img, double x0, double y0, double x1, double y1, const Color& c, int thick = 2, int dash = 0) {
  const double len = std::hypot(x1 - x0, y1 - y0);
  const int n = std::max(1, int(std::ceil(len)));
  for (int i = 0; i <= n; ++i) {
    if (dash > 0 && (i / dash) % 2 == 1) continue;
    const double s = double(i) / n;
    const int x = int(std::lround(x0 + s * (x1 - x0))), y = int(std::lround(y0 + s * (y1 - y0)));
    for (int dy = -(thick - 1) / 2; dy <= thick / 2; ++dy)
      for (int dx = -(thick - 1) / 2; dx <= thick / 2; ++dx) put(img, x + dx, y + dy, c);
  }
}

void disc(Image& img, int cx, int cy, int r, const Color& c) {
  for (int y = -r; y <= r; ++y)
    for (int x = -r; x <= r; ++x)
      if (x * x + y * y <= r * r) put(img, cx + x, cy + y, c);
}

void cross(Image& img, int cx, int cy, int r, const Color& c) {
  line(img, cx - r, cy - r, cx + r, cy + r, c, 2);
  line(img, cx - r, cy + r, cx + r, cy - r, c, 2);
}

std::string number_label(double v) {
  char buf[32];
  if (v >= 1e6)
    std::snprintf(buf, sizeof buf, "%gM", std::round(v / 1e5) / 10);
  else if (v >= 1e3)
    std::snprintf(buf, sizeof buf, "%gk", std::round(v / 1e2) / 10);
  else if (v < 1e-2)
    std::snprintf(buf, sizeof buf, "%.0e", v);
  else if (v >= 1)
    std::snprintf(buf, sizeof buf, "%g", v);
  else
    std::snprintf(buf, sizeof buf, "%.2g", v);
  return buf;
}

const Color kPalette[] = {{0.12f, 0.47f, 0.71f}, {1.0f, 0.50f, 0.05f}, {0.17f, 0.63f, 0.17f},
                          {0.84f, 0.15f, 0.16f}, {0.58f, 0.40f, 0.74f}, {0.55f, 0.34f, 0.29f},
                          {0.89f, 0.47f, 0.76f}, {0.50f, 0.50f, 0.50f}};

// A [lo, hi] range in log10 that covers [vmin, vmax] with nice bounds: whole decades,
// or halves of decades (1, 2, 5 steps) when the data spans less than a decade.
void log_range(double vmin, double vmax, double& lo, double& hi) {
  const double a = std::log10(vmin), b = std::log10(vmax);
  lo = std::floor(a);
  hi = std::ceil(b);
  if (hi <= lo) hi = lo + 1;
  // Tighten to the 1-2-5 ladder when that loses nothing.
  for (double f : {std::log10(5.0), std::log10(2.0)})
    if (lo + f <= a) {
      lo += f;
      break;
    }
  for (double f : {std::log10(5.0), std::log10(2.0)})
    if (hi - 1 + f >= b && hi - 1 + f > lo) {
      hi = hi - 1 + f;
      break;
    }
}

// One panel: axes, ticks, grid, series, legend.
Image panel(const std::vector<Series>& series, const std::string& title, const std::string& xlabel,
            const std::map<std::string, Color>& colors) {
  const int W = 620, H = 500;
  const int L = 78, R = 34, T = 40, B = 64;  // plot area margins
  Image img(W, H, Color(1, 1, 1));
  const Color black(0, 0, 0), grid(0.88f, 0.88f, 0.88f), grid_major(0.75f, 0.75f, 0.75f);
  double xmin = INFINITY, xmax = 0, tmin = INFINITY, tmax = 0;
  for (auto& s : series)
    for (auto& p : s.points) {
      if (p.x > 0) xmin = std::min(xmin, p.x), xmax = std::max(xmax, p.x);
      if (p.ok && p.t > 0) tmin = std::min(tmin, p.t), tmax = std::max(tmax, p.t);
    }
  shapemap::draw_text(img, L, 10, title, black, 2);
  if (!(xmax > 0)) {
    shapemap::draw_text(img, L, H / 2, "no runs", black, 2);
    return img;
  }
  if (!(tmax > 0)) tmin = 0.1, tmax = 10;
  double x0, x1, y0, y1;
  log_range(xmin, xmax, x0, x1);
  log_range(tmin, tmax, y0, y1);
  const int pw = W - L - R, ph = H - T - B;
  {  // Headroom above the data for the legend.
    const double frac = std::min(0.6, (20.0 * series.size() + 30.0) / ph);
    y1 = y0 + (std::log10(tmax) - y0) / (1 - frac);
  }
  auto X = [&](double v) { return L + (std::log10(v) - x0) / (x1 - x0) * pw; };
  auto Y = [&](double v) { return T + ph - (std::log10(v) - y0) / (y1 - y0) * ph; };
  // Grid and ticks: every m * 10^d inside the range; labels on 1, 2, 5 (on 1 only when
  // the axis spans more than two decades).
  auto ticks = [&](double lo, double hi, bool xaxis) {
    const bool many = hi - lo > 2.01;
    for (int d = int(std::floor(lo)) - 1; d <= int(std::ceil(hi)); ++d)
      for (int m = 1; m <= 9; ++m) {
        const double v = m * std::pow(10.0, d), l = std::log10(v);
        if (l < lo - 1e-9 || l > hi + 1e-9) continue;
        const bool major = m == 1;
        const bool label = major || (!many && (m == 2 || m == 5));
        if (xaxis) {
          const int px = int(std::lround(X(v)));
          line(img, px, T, px, T + ph, major ? grid_major : grid, 1);
          line(img, px, T + ph, px, T + ph + (major ? 7 : 4), black, 1);
          if (label) {
            const std::string s = number_label(v);
            shapemap::draw_text(img, px - shapemap::text_width(s, 2) / 2, T + ph + 10, s, black, 2);
          }
        } else {
          const int py = int(std::lround(Y(v)));
          line(img, L, py, L + pw, py, major ? grid_major : grid, 1);
          line(img, L - (major ? 7 : 4), py, L, py, black, 1);
          if (label) {
            const std::string s = number_label(v);
            shapemap::draw_text(img, L - 10 - shapemap::text_width(s, 2), py - 7, s, black, 2);
          }
        }
      }
  };
  ticks(x0, x1, true);
  ticks(y0, y1, false);
  line(img, L, T, L, T + ph, black, 2);
  line(img, L, T + ph, L + pw, T + ph, black, 2);
  line(img, L, T, L + pw, T, black, 1);
  line(img, L + pw, T, L + pw, T + ph, black, 1);
  shapemap::draw_text(img, L + (pw - shapemap::text_width(xlabel, 2)) / 2, H - 26, xlabel, black, 2);
  // Vertical axis label, written horizontally above the axis.
  shapemap::draw_text(img, 6, T - 16, "seconds", black, 1);

  // Series: fitted line (dashed), measured polyline, points, failures.
  for (auto& s : series) {
    const Color c = colors.at(s.method);
    std::vector<Point> ok;
    for (auto& p : s.points)
      if (p.ok && p.t > 0 && p.x > 0) ok.push_back(p);
    std::sort(ok.begin(), ok.end(), [](const Point& a, const Point& b) { return a.x < b.x; });
    if (std::isfinite(s.slope) && ok.size() >= 2) {
      const double a = ok.front().x, b = ok.back().x;
      line(img, X(a), Y(std::pow(10.0, s.intercept + s.slope * std::log10(a))), X(b),
           Y(std::pow(10.0, s.intercept + s.slope * std::log10(b))), c * 0.6f + Color(0.4f, 0.4f, 0.4f), 1, 5);
    }
    for (size_t i = 1; i < ok.size(); ++i) line(img, X(ok[i - 1].x), Y(ok[i - 1].t), X(ok[i].x), Y(ok[i].t), c, 2);
    for (auto& p : ok) disc(img, int(std::lround(X(p.x))), int(std::lround(Y(p.t))), 4, c);
  }
  // Legend (top left inside the plot).
  int ly = T + 10;
  int lw = 0;
  std::vector<std::string> texts;
  for (auto& s : series) {
    int failed = 0;
    for (auto& p : s.points) failed += !p.ok;
    char buf[160];
    if (std::isfinite(s.slope))
      std::snprintf(buf, sizeof buf, "%s  k = %.2f", s.method.c_str(), s.slope);
    else
      std::snprintf(buf, sizeof buf, "%s  k = n/a", s.method.c_str());
    std::string t = buf;
    if (failed) t += "  (" + std::to_string(failed) + " failed: x)";
    texts.push_back(t);
    lw = std::max(lw, shapemap::text_width(t, 2));
  }
  const int lx = L + 12;
  img.fill_rect(lx - 6, ly - 6, lx + 30 + lw + 8, ly + 20 * int(series.size()) + 18, Color(1, 1, 1));
  for (size_t i = 0; i < series.size(); ++i) {
    const Color c = colors.at(series[i].method);
    line(img, lx, ly + 7, lx + 22, ly + 7, c, 2);
    disc(img, lx + 11, ly + 7, 4, c);
    shapemap::draw_text(img, lx + 30, ly, texts[i], black, 2);
    ly += 20;
  }
  shapemap::draw_text(img, lx, ly + 2, "fit: t ~ n^k (least squares, log-log)", Color(0.3f, 0.3f, 0.3f), 1);
  // Failed runs: crosses on the top edge at their size (over the legend if need be).
  for (auto& s : series)
    for (auto& p : s.points)
      if (!p.ok && p.x > 0) cross(img, int(std::lround(X(p.x))), T + 6, 5, colors.at(s.method));
  return img;
}

int usage() {
  std::cerr << "usage: tool_plot [RESULTS.json] [-o PNG]\n"
               "  Draws time against size (log-log) per method from bench/results.json with the\n"
               "  fitted growth exponent per method. Defaults: bench/results.json, bench/scaling.png\n";
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  std::string in = "bench/results.json", out = "bench/scaling.png";
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    if (a == "-h" || a == "--help") return usage(), 0;
    if ((a == "-o" || a == "--output") && i + 1 < argc)
      out = argv[++i];
    else if (!a.empty() && a[0] != '-')
      in = a;
    else
      return usage();
  }
  nlohmann::json j;
  try {
    std::ifstream f(in);
    if (!f) {
      std::cerr << "tool_plot: error: " << in << ": cannot open\n";
      return 2;
    }
    j = nlohmann::json::parse(f);
  } catch (const std::exception& e) {
    std::cerr << "tool_plot: error: " << in << ": " << e.what() << "\n";
    return 2;
  }
  // measure -> method -> series, in order of first appearance.
  std::vector<std::string> measures;
  std::map<std::string, std::vector<Series>> panels;
  std::map<std::string, Color> colors;
  if (!j.contains("runs") || !j["runs"].is_array()) {
    std::cerr << "tool_plot: error: " << in << ": no \"runs\" array\n";
    return 2;
  }
  for (auto& r : j["runs"]) {
    if (!r.value("plot", true)) continue;
    const std::string method = r.value("method", std::string("?"));
    const std::string measure = r.value("x_measure", std::string("size"));
    const double x = r.value("x", 0.0);
    double t = 0;
    if (r.contains("seconds") && r["seconds"].is_number()) t = r["seconds"].get<double>();
    const bool ok = r.value("status", std::string()) == "ok";
    if (!panels.count(measure)) measures.push_back(measure);
    auto& v = panels[measure];
    auto it = std::find_if(v.begin(), v.end(), [&](const Series& s) { return s.method == method; });
    if (it == v.end()) {
      v.push_back(Series{method, {}});
      it = v.end() - 1;
    }
    it->points.push_back({x, t, ok});
    if (!colors.count(method)) colors[method] = kPalette[colors.size() % (sizeof kPalette / sizeof kPalette[0])];
  }
  if (measures.empty()) {
    std::cerr << "tool_plot: error: " << in << ": no runs to plot\n";
    return 2;
  }
  std::vector<Image> images;
  std::vector<std::string> captions;
  for (auto& m : measures) {
    auto& v = panels[m];
    for (auto& s : v) fit(s);
    const bool surf = m == "vertices";
    const std::string title = surf ? "surface maps" : m == "tets" ? "volume maps" : m;
    const std::string xl = surf ? "vertices of A" : m == "tets" ? "tets of A" : m;
    images.push_back(panel(v, title + ": wall time vs size", xl, colors));
    captions.push_back("");
    for (auto& s : v)
      std::printf("%-16s %-9s k = %s\n", s.method.c_str(), m.c_str(),
                  std::isfinite(s.slope) ? std::to_string(s.slope).c_str() : "n/a");
  }
  // Header line: machine and date, when recorded.
  std::string head = "shapemap bench/run";
  if (j.contains("machine") && j["machine"].is_object()) {
    const auto& mc = j["machine"];
    if (mc.contains("cores")) head += ", " + mc["cores"].dump() + " cores";
    if (mc.contains("threads")) head += ", threads " + mc["threads"].dump();
  }
  if (j.contains("date") && j["date"].is_string()) head += ", " + j["date"].get<std::string>();
  Image row = images.size() == 1 ? images[0] : shapemap::hconcat(images, captions);
  Image outimg(row.width, row.height + 28, Color(1, 1, 1));
  for (int y = 0; y < row.height; ++y)
    for (int x = 0; x < row.width; ++x) outimg.at(x, y + 28) = row.at(x, y);
  shapemap::draw_text(outimg, 10, 8, head, Color(0.2f, 0.2f, 0.2f), 2);
  try {
    shapemap::write_png(out, outimg);
  } catch (const std::exception& e) {
    std::cerr << "tool_plot: error: " << out << ": " << e.what() << "\n";
    return 1;
  }
  std::printf("wrote %s\n", out.c_str());
  return 0;
}

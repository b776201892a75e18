// Self-contained HTML reports: metrics tables from report.json and embedded PNGs.
#include "shapemap/render/report_html.h"
#include "shapemap/io.h"
#include <sstream>

namespace shapemap {

namespace {

std::string base64(const std::vector<unsigned char>& data) {
  static const char* tab = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((data.size() + 2) / 3 * 4);
  for (size_t i = 0; i < data.size(); i += 3) {
    unsigned v = unsigned(data[i]) << 16;
    if (i + 1 < data.size()) v |= unsigned(data[i + 1]) << 8;
    if (i + 2 < data.size()) v |= unsigned(data[i + 2]);
    out += tab[(v >> 18) & 63];
    out += tab[(v >> 12) & 63];
    out += i + 1 < data.size() ? tab[(v >> 6) & 63] : '=';
    out += i + 2 < data.size() ? tab[v & 63] : '=';
  }
  return out;
}

std::string escape(const std::string& s) {
  std::string o;
  for (char c : s) {
    if (c == '<') o += "&lt;";
    else if (c == '>') o += "&gt;";
    else if (c == '&') o += "&amp;";
    else o += c;
  }
  return o;
}

std::string scalar_text(const nlohmann::json& v) {
  if (v.is_number_float()) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.6g", v.get<double>());
    return buf;
  }
  if (v.is_string()) return v.get<std::string>();
  return v.dump();
}

// Nested objects become nested tables; arrays of numbers longer than 12 are summarized.
void table(std::ostringstream& o, const nlohmann::json& j) {
  o << "<table>";
  for (auto it = j.begin(); it != j.end(); ++it) {
    o << "<tr><th>" << escape(j.is_object() ? it.key() : std::to_string(std::distance(j.begin(), it)))
      << "</th><td>";
    const auto& v = it.value();
    if (v.is_object()) table(o, v);
    else if (v.is_array() && v.size() > 12) o << "[" << v.size() << " values]";
    else if (v.is_array()) {
      bool flat = true;
      for (auto& e : v) flat = flat && !e.is_structured();
      if (flat) {
        std::string s;
        for (auto& e : v) s += (s.empty() ? "" : ", ") + scalar_text(e);
        o << escape(s);
      } else table(o, v);
    } else o << escape(scalar_text(v));
    o << "</td></tr>";
  }
  o << "</table>";
}

}  // namespace

std::string report_html(const std::string& title, const nlohmann::json& report, const std::vector<Figure>& figures) {
  std::ostringstream o;
  o << "<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>" << escape(title) << "</title><style>"
    << "body{font-family:sans-serif;margin:2em;max-width:1400px}table{border-collapse:collapse;margin:2px}"
    << "th,td{border:1px solid #ccc;padding:2px 6px;text-align:left;vertical-align:top;font-size:13px}"
    << "th{background:#f3f3f3}figure{display:inline-block;margin:8px}img{max-width:100%;border:1px solid #ddd}"
    << "</style></head><body><h1>" << escape(title) << "</h1>";
  for (auto& f : figures) {
    o << "<figure><img alt=\"" << escape(f.caption) << "\" src=\"data:image/png;base64,"
      << base64(encode_png(f.image)) << "\"><figcaption>" << escape(f.caption) << "</figcaption></figure>";
  }
  o << "<h2>Report</h2>";
  table(o, report);
  o << "</body></html>\n";
  return o.str();
}

void write_report_html(const std::string& path, const std::string& title, const nlohmann::json& report,
                       const std::vector<Figure>& figures) {
  write_text_atomic(path, report_html(title, report, figures));
}

}  // namespace shapemap

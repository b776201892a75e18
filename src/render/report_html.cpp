// HTML reports: metrics tables from report.json, embedded PNGs and, when the viewer files
// are beside it, the interactive 3D views (report_viewer.h).
#include "shapemap/render/report_html.h"
#include "shapemap/render/base64.h"
#include "shapemap/io.h"
#include <sstream>

namespace shapemap {

std::string html_escape(const std::string& s) {
  std::string o;
  for (char c : s) {
    if (c == '<') o += "&lt;";
    else if (c == '>') o += "&gt;";
    else if (c == '&') o += "&amp;";
    else if (c == '"') o += "&quot;";
    else o += c;
  }
  return o;
}

namespace {

std::string scalar_text(const nlohmann::json& v) {
  if (v.is_number_float()) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.6g", v.get<double>());
    return buf;
  }
  if (v.is_string()) return v.get<std::string>();
  return v.dump();
}

// JSON pointer token (RFC 6901): the tests match each table cell to report.json by it.
std::string pointer_token(const std::string& k) {
  std::string o;
  for (char c : k) {
    if (c == '~') o += "~0";
    else if (c == '/') o += "~1";
    else o += c;
  }
  return o;
}

// Nested objects become nested tables; arrays of numbers longer than 12 are summarized.
// Each scalar cell carries data-ptr, the JSON pointer of its value in report.json.
void table(std::ostringstream& o, const nlohmann::json& j, const std::string& ptr) {
  o << "<table>";
  for (auto it = j.begin(); it != j.end(); ++it) {
    const std::string key = j.is_object() ? it.key() : std::to_string(std::distance(j.begin(), it));
    const std::string p = ptr + "/" + pointer_token(key);
    const auto& v = it.value();
    o << "<tr><th>" << html_escape(key) << "</th><td";
    if (!v.is_structured()) o << " data-ptr=\"" << html_escape(p) << "\"";
    o << ">";
    if (v.is_object()) table(o, v, p);
    else if (v.is_array() && v.size() > 12) o << "[" << v.size() << " values]";
    else if (v.is_array()) {
      bool flat = true;
      for (auto& e : v) flat = flat && !e.is_structured();
      if (flat) {
        std::string s;
        for (auto& e : v) s += (s.empty() ? "" : ", ") + scalar_text(e);
        o << html_escape(s);
      } else table(o, v, p);
    } else o << html_escape(scalar_text(v));
    o << "</td></tr>";
  }
  o << "</table>";
}

}  // namespace

std::string report_html(const std::string& title, const nlohmann::json& report, const std::vector<Figure>& figures,
                        bool viewer) {
  std::ostringstream o;
  o << "<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>" << html_escape(title) << "</title><style>"
    << "body{font-family:sans-serif;margin:1em 2em;max-width:1600px}table{border-collapse:collapse;margin:2px}"
    << "th,td{border:1px solid #ccc;padding:2px 6px;text-align:left;vertical-align:top;font-size:13px}"
    << "th{background:#f3f3f3}figure{display:inline-block;margin:8px}img{max-width:100%;border:1px solid #ddd}"
    << "#top{display:flex;gap:1em;align-items:flex-start}#views{flex:2 1 700px;min-width:400px}"
    << "#side{flex:1 1 350px;max-height:80vh;overflow:auto}"
    << "</style></head><body><h1>" << html_escape(title) << "</h1><div id=\"top\">";
  if (viewer) {
    o << "<div id=\"views\"><noscript>The 3D views need JavaScript.</noscript></div>";
  }
  o << "<div id=\"side\">";
  if (report.contains("timings") && report["timings"].is_object()) {
    o << "<h2>Stage timings (s)</h2>";
    table(o, report["timings"], "/timings");
  }
  o << "<h2>Report</h2>";
  table(o, report, "");
  o << "</div></div><h2>Pictures</h2>";
  for (auto& f : figures) {
    const std::vector<unsigned char> png = encode_png(f.image);
    o << "<figure><img alt=\"" << html_escape(f.caption) << "\" src=\"data:image/png;base64,"
      << base64_encode(png.data(), png.size()) << "\"><figcaption>" << html_escape(f.caption)
      << "</figcaption></figure>";
  }
  if (viewer) {
    // Plain scripts (not modules, not fetch): they load from file:// with no server.
    o << "<script src=\"three.min.js\"></script><script src=\"report_data.js\"></script>"
      << "<script src=\"report_viewer.js\"></script>";
  }
  o << "</body></html>\n";
  return o.str();
}

void write_report_html(const std::string& path, const std::string& title, const nlohmann::json& report,
                       const std::vector<Figure>& figures, bool viewer) {
  write_text_atomic(path, report_html(title, report, figures, viewer));
}

}  // namespace shapemap

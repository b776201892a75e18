// report.html: a page (PNG pictures embedded as data URIs) with the metrics of a report.json
// as tables, viewable offline. With `viewer`, it also loads three.min.js, report_data.js and
// report_viewer.js from its folder and shows the interactive 3D views (report_viewer.h).
// Every scalar cell of the report table has data-ptr = the JSON pointer of its value.
#pragma once
#include "shapemap/render/image.h"
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

namespace shapemap {

struct Figure {
  std::string caption;
  Image image;
};

// s with < > & " replaced by their HTML entities (text and attribute values).
std::string html_escape(const std::string& s);

std::string report_html(const std::string& title, const nlohmann::json& report,
                        const std::vector<Figure>& figures, bool viewer = false);
// Writes report_html(...) to path atomically.
void write_report_html(const std::string& path, const std::string& title,
                       const nlohmann::json& report, const std::vector<Figure>& figures,
                       bool viewer = false);

}  // namespace shapemap

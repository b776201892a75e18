// report.html: a self-contained page (PNG pictures embedded as data URIs) with the
// metrics of a report.json as tables, viewable offline.
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

std::string report_html(const std::string& title, const nlohmann::json& report,
                        const std::vector<Figure>& figures);
// Writes report_html(...) to path atomically.
void write_report_html(const std::string& path, const std::string& title,
                       const nlohmann::json& report, const std::vector<Figure>& figures);

}  // namespace shapemap

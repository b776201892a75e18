// Base64 (RFC 4648, with padding): PNGs as data URIs in report.html and the viewer's binary
// buffers in report_data.js (file:// pages cannot fetch() local files, but they can run a
// <script src> that holds the bytes as text).
#pragma once
#include <cstddef>
#include <string>

namespace shapemap {

std::string base64_encode(const unsigned char* data, size_t size);

}  // namespace shapemap

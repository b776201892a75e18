#include "shapemap/render/base64.h"

namespace shapemap {

std::string base64_encode(const unsigned char* data, size_t size) {
  static const char* tab = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((size + 2) / 3 * 4);
  for (size_t i = 0; i < size; i += 3) {
    unsigned v = unsigned(data[i]) << 16;
    if (i + 1 < size) v |= unsigned(data[i + 1]) << 8;
    if (i + 2 < size) v |= unsigned(data[i + 2]);
    out += tab[(v >> 18) & 63];
    out += tab[(v >> 12) & 63];
    out += i + 1 < size ? tab[(v >> 6) & 63] : '=';
    out += i + 2 < size ? tab[v & 63] : '=';
  }
  return out;
}

}  // namespace shapemap

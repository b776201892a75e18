// Internal helpers shared by the readers and writers of src/core/io_*.cpp: a bounded
// parser over an in-memory file (text tokens with line numbers, and binary values of
// either byte order), number formatting, and vertex-id lookup. Not a public header.
//
// Every reader loads the whole file, then walks it with a Parser. All failures go
// through Parser::fail, which throws InputError("<path>:<line>: <problem>"). Counts
// read from headers are checked against the bytes left before anything is allocated.
#pragma once
#include "shapemap/error.h"
#include "shapemap/mesh.h"
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace shapemap::detail {

// The whole file as bytes. Throws InputError("<path>: cannot open ...") if missing,
// a folder, or unreadable.
std::string read_file_bytes(const std::string& path);

// Writes bytes to path atomically (temporary file in the same folder, then rename).
void write_bytes_atomic(const std::string& path, const std::string& bytes);

// Lower-case extension with the dot (".obj"), or "" if none.
std::string extension(const std::string& path);

// Tets with more negative than positive volumes are flipped (all of them), so a file
// written with the opposite orientation convention reads positively oriented.
void orient_tets_positive(TetMesh& mesh);

// Appends the shortest text that reads back to exactly the same double.
inline void append_double(std::string& out, double x) {
  char buf[40];
  auto r = std::to_chars(buf, buf + sizeof buf, x);
  out.append(buf, r.ptr);
}
inline void append_int(std::string& out, long long x) {
  char buf[24];
  auto r = std::to_chars(buf, buf + sizeof buf, x);
  out.append(buf, r.ptr);
}
// Row r of a vertex or element matrix, each value after a space: the body of most lines the
// text writers write. `base` is added to indices (1 for 1-based formats).
inline void append_row(std::string& out, const Eigen::MatrixXd& M, Eigen::Index r) {
  for (Eigen::Index j = 0; j < M.cols(); ++j) {
    out += ' ';
    append_double(out, M(r, j));
  }
}
inline void append_row(std::string& out, const Eigen::MatrixXi& M, Eigen::Index r, int base = 0) {
  for (Eigen::Index j = 0; j < M.cols(); ++j) {
    out += ' ';
    append_int(out, M(r, j) + base);
  }
}

inline bool iequals(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    char x = a[i], y = b[i];
    if (x >= 'A' && x <= 'Z') x = char(x - 'A' + 'a');
    if (y >= 'A' && y <= 'Z') y = char(y - 'A' + 'a');
    if (x != y) return false;
  }
  return true;
}

// A short, printable rendering of a token for error messages.
std::string quote(std::string_view tok);

class Parser {
 public:
  // skip_bom: start after a UTF-8 byte-order mark (EF BB BF), which editors on Windows put
  // in front of text files; off for formats whose first bytes may be binary (STL).
  Parser(std::string path, const std::string& data, bool skip_bom = true)
      : path_(std::move(path)), begin_(data.data()), p_(data.data()), end_(data.data() + data.size()) {
    if (skip_bom && has_utf8_bom(data)) p_ += 3;
  }
  static bool has_utf8_bom(const std::string& data) {
    return data.size() >= 3 && std::memcmp(data.data(), "\xEF\xBB\xBF", 3) == 0;
  }

  const std::string& path() const { return path_; }
  int line() const { return line_; }
  size_t remaining() const { return size_t(end_ - p_); }
  size_t offset() const { return size_t(p_ - begin_); }
  bool eof() const { return p_ >= end_; }
  const char* pos() const { return p_; }
  // Lines starting with this character (after blanks) are comments in next_token();
  // 0 = no comments. A comment character inside a line starts a comment too.
  char comment = 0;

  [[noreturn]] void fail(const std::string& problem) const { fail_at(line_, problem); }
  [[noreturn]] void fail_at(int line, const std::string& problem) const {
    throw InputError(path_ + ":" + std::to_string(line) + ": " + problem);
  }

  // ---- text ---------------------------------------------------------------------
  // Line ends: \n, \r\n, or a lone \r (old Mac files). The \r of \r\n is a blank.
  bool newline_at(const char* q) const {
    return q < end_ && (*q == '\n' || (*q == '\r' && (q + 1 >= end_ || q[1] != '\n')));
  }
  // Skips blanks (space, tab, \r before \n, \f, \v) but not newlines.
  void skip_blanks() {
    while (p_ < end_ && (*p_ == ' ' || *p_ == '\t' || *p_ == '\f' || *p_ == '\v' || (*p_ == '\r' && !newline_at(p_))))
      ++p_;
  }
  // True at a newline, a comment, or the end (after skipping blanks).
  bool at_eol() {
    skip_blanks();
    return p_ >= end_ || newline_at(p_) || (comment && *p_ == comment);
  }
  // Moves past the next newline (or to the end).
  void skip_line() {
    while (p_ < end_ && !newline_at(p_)) ++p_;
    if (p_ < end_) {
      ++p_;
      ++line_;
    }
  }
  // Skips blanks, newlines and comments.
  // skip_space(), then false at the end: `while (P.more())` walks a file of one record a line.
  bool more() {
    skip_space();
    return !eof();
  }
  void skip_space() {
    for (;;) {
      skip_blanks();
      if (p_ >= end_) return;
      if (newline_at(p_)) {
        ++p_;
        ++line_;
      } else if (comment && *p_ == comment) {
        while (p_ < end_ && !newline_at(p_)) ++p_;
      } else {
        return;
      }
    }
  }
  // The next token on the current line ("" at the end of the line).
  std::string_view line_token() {
    if (at_eol()) return {};
    return take_token();
  }
  // The next token anywhere ("" at the end of the file).
  std::string_view next_token() {
    skip_space();
    if (p_ >= end_) return {};
    return take_token();
  }
  // The next token without consuming it.
  std::string_view peek_token() {
    const char* p = p_;
    int l = line_;
    std::string_view t = next_token();
    p_ = p;
    line_ = l;
    return t;
  }
  // The rest of the current line (without the newline), consumed with the newline.
  std::string_view rest_of_line() {
    const char* s = p_;
    while (p_ < end_ && !newline_at(p_)) ++p_;
    std::string_view r(s, size_t(p_ - s));
    if (p_ < end_) {
      ++p_;
      ++line_;
    }
    while (!r.empty() && (r.back() == '\r' || r.back() == ' ' || r.back() == '\t')) r.remove_suffix(1);
    return r;
  }

  // Numbers from tokens. `what` names the value in messages ("vertex 3 x").
  double to_double(std::string_view tok, std::string_view what) const {
    if (tok.empty()) fail("expected " + std::string(what) + ", found end of " + (p_ >= end_ ? "file" : "line"));
    const char* s = tok.data();
    const char* e = s + tok.size();
    if (*s == '+') ++s;
    double x = 0;
    auto r = std::from_chars(s, e, x);
    if (r.ec == std::errc::result_out_of_range && r.ptr == e) {
      // Underflow (1e-400) reads as 0 or a subnormal, as strtod gives it; overflow is an error.
      x = std::strtod(std::string(s, e).c_str(), nullptr);
      if (std::isfinite(x)) return x;
    }
    if (r.ec == std::errc::result_out_of_range) fail(std::string(what) + " " + quote(tok) + " is out of range");
    if (r.ec != std::errc() || r.ptr != e) fail("expected " + std::string(what) + ", found " + quote(tok));
    if (!std::isfinite(x)) fail(std::string(what) + " is not finite (" + quote(tok) + ")");
    return x;
  }
  long long to_int(std::string_view tok, std::string_view what) const {
    if (tok.empty()) fail("expected " + std::string(what) + ", found end of " + (p_ >= end_ ? "file" : "line"));
    const char* s = tok.data();
    const char* e = s + tok.size();
    if (*s == '+') ++s;
    long long x = 0;
    auto r = std::from_chars(s, e, x);
    if (r.ec == std::errc::result_out_of_range) fail(std::string(what) + " " + quote(tok) + " is out of range");
    if (r.ec != std::errc() || r.ptr != e) fail("expected " + std::string(what) + " (an integer), found " + quote(tok));
    return x;
  }
  double next_double(std::string_view what) { return to_double(next_token(), what); }
  long long next_int(std::string_view what) { return to_int(next_token(), what); }
  double line_double(std::string_view what) { return to_double(line_token(), what); }
  long long line_int(std::string_view what) { return to_int(line_token(), what); }

  // A count from a header: non-negative, at most INT_MAX, and each item needing at
  // least min_bytes of the bytes left, so a garbled count never allocates.
  int check_count(long long n, double min_bytes, const std::string& what) const {
    if (n < 0) fail(what + " count " + std::to_string(n) + " is negative");
    if (n > 2147483647LL) fail(what + " count " + std::to_string(n) + " is too large");
    if (double(n) * min_bytes > double(remaining()) + 1)
      fail(what + " count " + std::to_string(n) + " does not fit in the rest of the file (" +
           std::to_string(remaining()) + " bytes left): truncated or corrupt");
    return int(n);
  }

  // ---- binary -------------------------------------------------------------------
  void need(size_t n, std::string_view what) const {
    if (remaining() < n)
      fail("truncated binary data: " + std::string(what) + " needs " + std::to_string(n) + " bytes, " +
           std::to_string(remaining()) + " left (byte offset " + std::to_string(offset()) + ")");
  }
  void skip_bytes(size_t n, std::string_view what) {
    need(n, what);
    p_ += n;
  }
  // Reads a raw value of type T in the given byte order (big_endian or little).
  template <class T>
  T read(bool big_endian, std::string_view what) {
    need(sizeof(T), what);
    unsigned char b[sizeof(T)];
    std::memcpy(b, p_, sizeof(T));
    p_ += sizeof(T);
    if (big_endian != host_big_endian())
      for (size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
    T v;
    std::memcpy(&v, b, sizeof(T));
    return v;
  }
  // Moves the position (used after a binary block followed by text).
  void set_pos(const char* p) { p_ = p; }
  void add_lines(int n) { line_ += n; }

  static bool host_big_endian() {
    const std::uint16_t x = 1;
    unsigned char c;
    std::memcpy(&c, &x, 1);
    return c == 0;
  }

 private:
  std::string_view take_token() {
    const char* s = p_;
    while (p_ < end_ && !(*p_ == ' ' || *p_ == '\t' || *p_ == '\r' || *p_ == '\n' || *p_ == '\f' ||
                          *p_ == '\v' || (comment && *p_ == comment)))
      ++p_;
    return std::string_view(s, size_t(p_ - s));
  }

  std::string path_;
  const char* begin_;
  const char* p_;
  const char* end_;
  int line_ = 1;
};

// A text file read whole and a Parser over it, '#' starting comments: how the text readers
// begin. Not copyable: the parser points into `data`.
struct TextFile {
  explicit TextFile(const std::string& path) : data(read_file_bytes(path)), P(path, data) { P.comment = '#'; }
  TextFile(const TextFile&) = delete;
  TextFile& operator=(const TextFile&) = delete;
  std::string data;
  Parser P;
};

// Vertex ids of files that number vertices freely (gmsh tags, TetGen indices):
// id -> 0-based row. Fast path for consecutive ids.
class IdMap {
 public:
  void add(long long id, int row) { ids_.push_back({id, row}); }
  // Sorts; returns the first duplicated id through *dup (true if any).
  bool finish(long long* dup) {
    consecutive_ = true;
    for (size_t i = 0; i < ids_.size(); ++i)
      if (ids_[i].first != ids_[0].first + (long long)i || ids_[i].second != int(i)) consecutive_ = false;
    if (consecutive_) return false;
    std::sort(ids_.begin(), ids_.end());
    for (size_t i = 1; i < ids_.size(); ++i)
      if (ids_[i].first == ids_[i - 1].first) {
        *dup = ids_[i].first;
        return true;
      }
    return false;
  }
  // -1 if unknown.
  int find(long long id) const {
    if (ids_.empty()) return -1;
    if (consecutive_) {
      long long r = id - ids_[0].first;
      return (r >= 0 && r < (long long)ids_.size()) ? int(r) : -1;
    }
    auto it = std::lower_bound(ids_.begin(), ids_.end(), std::make_pair(id, -1));
    return (it != ids_.end() && it->first == id) ? it->second : -1;
  }
  size_t size() const { return ids_.size(); }

 private:
  std::vector<std::pair<long long, int>> ids_;
  bool consecutive_ = true;
};

// Packs rows of doubles / ints (flat, row-major) into Eigen matrices.
template <class Scalar>
Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic> to_matrix(const std::vector<Scalar>& flat, int cols) {
  const Eigen::Index rows = Eigen::Index(flat.size() / size_t(cols));
  Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic> M(rows, cols);
  for (Eigen::Index i = 0; i < rows; ++i)
    for (int j = 0; j < cols; ++j) M(i, j) = flat[size_t(i) * cols + j];
  return M;
}

// The readers' last check: a file that gave no vertices or no `elements` is an error.
inline void require_read(const std::string& path, const std::vector<double>& V, const std::vector<int>& E,
                         const char* elements) {
  if (V.empty()) throw InputError(path + ": no vertices");
  if (E.empty()) throw InputError(path + ": no " + std::string(elements));
}

// Surface / volume readers and writers by format (io_surface.cpp, io_volume.cpp).
TriMesh read_obj(const std::string& path);
TriMesh read_off(const std::string& path);
TriMesh read_ply(const std::string& path);
TriMesh read_stl(const std::string& path);
void write_obj(const std::string& path, const TriMesh& m);
void write_off(const std::string& path, const TriMesh& m);
void write_ply(const std::string& path, const TriMesh& m);
void write_stl(const std::string& path, const TriMesh& m);

TetMesh read_medit(const std::string& path);
TetMesh read_vtk(const std::string& path);
TetMesh read_gmsh(const std::string& path);
TetMesh read_tetgen(const std::string& path);
void write_medit(const std::string& path, const TetMesh& m);
void write_gmsh(const std::string& path, const TetMesh& m);
void write_tetgen(const std::string& path, const TetMesh& m);

}  // namespace shapemap::detail

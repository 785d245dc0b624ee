#include "service/text/input_limits.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <vector>

namespace coopdyn::text {

namespace {
bool continuation(const std::string& s, size_t i) {
  return i < s.size() && (static_cast<unsigned char>(s[i]) & 0xC0) == 0x80;
}
size_t utf8_back(const std::string& s, size_t i) {
  while (i > 0 && continuation(s, i)) --i;
  return i;
}
size_t utf8_fwd(const std::string& s, size_t i) {
  while (continuation(s, i)) ++i;
  return i;
}
DepthExceeded at(const std::string& t, size_t offset) {
  DepthExceeded r;
  r.exceeded = true;
  r.line = 1;
  size_t line_start = 0;
  for (size_t i = 0; i < offset && i < t.size(); ++i)
    if (t[i] == '\n') {
      ++r.line;
      line_start = i + 1;
    }
  r.column = static_cast<int>(offset - line_start) + 1;
  return r;
}
bool space(char c) { return c == ' ' || c == '\t' || c == '\r'; }
}  // namespace

std::string shown(const std::string& v, size_t max_chars) {
  if (v.size() <= max_chars || max_chars < 5) return v;
  const size_t tail = (max_chars - 3) / 3, head = max_chars - 3 - tail;
  return v.substr(0, utf8_back(v, head)) + "..." + v.substr(utf8_fwd(v, v.size() - tail));
}

std::string cut_values(const std::string& msg) {
  std::string out;
  out.reserve(std::min(msg.size(), kMaxMessageChars + 64));
  for (size_t i = 0; i < msg.size();) {
    const char c = msg[i];
    if (c != '\'' && c != '"') {
      out += c;
      ++i;
      continue;
    }
    const size_t j = msg.find(c, i + 1);
    if (j == std::string::npos) {
      out.append(msg, i, std::string::npos);
      break;
    }
    out += c;
    out += shown(msg.substr(i + 1, j - i - 1));
    out += c;
    i = j + 1;
  }
  if (out.size() > kMaxMessageChars) {
    const size_t k = utf8_back(out, kMaxMessageChars);
    const size_t more = out.size() - k;
    out = out.substr(0, k) + " ... (" + std::to_string(more) + " more characters)";
  }
  return out;
}

bool read_file(const std::string& path, size_t max_bytes, const std::string& noun, std::string* out, std::string* why) {
  // O_NONBLOCK: opening a FIFO must not wait for a writer; it is refused just below anyway
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) {
    *why = "cannot open " + noun + " (" + std::strerror(errno) + ")";
    return false;
  }
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    *why = noun + " is not a regular file";
    return false;
  }
  auto too_big = [&](unsigned long long size) {
    *why = noun + " is " + std::to_string(size) + " bytes, more than the limit of " + std::to_string(max_bytes);
    return false;
  };
  if (static_cast<unsigned long long>(st.st_size) > max_bytes) {
    ::close(fd);
    return too_big(static_cast<unsigned long long>(st.st_size));
  }
  out->clear();
  out->resize(static_cast<size_t>(st.st_size) + 1);
  size_t got = 0;
  for (;;) {  // the file may have grown since fstat: read at most max_bytes + 1
    if (got == out->size()) {
      if (got > max_bytes) break;
      out->resize(std::min(max_bytes + 1, 2 * got + 4096));
    }
    const ssize_t r = ::read(fd, &(*out)[got], out->size() - got);
    if (r < 0 && errno == EINTR) continue;
    if (r < 0) {
      *why = "cannot read " + noun + " (" + std::strerror(errno) + ")";
      ::close(fd);
      return false;
    }
    if (r == 0) break;
    got += static_cast<size_t>(r);
  }
  ::close(fd);
  if (got > max_bytes) return too_big(got);
  out->resize(got);
  return true;
}

DepthExceeded yaml_depth_exceeds(const std::string& t, int max_depth) {
  // An upper bound of yaml-cpp's nesting depth, line by line. An indentation level can hold two
  // collections (`key:` with its `- item` sequence at the same indentation), so it counts 2; each
  // compact indicator ("- ", "? ", ": ") and each open [ or { counts 1.
  std::vector<int> indents;  // block indentation levels open at this line
  int flow = 0;              // open [ and { (flow collections may span lines)
  char quote = 0;            // inside a quoted scalar that spans lines
  int block_scalar = -1;     // inside a | or > block scalar: lines indented more than this are text
  const size_t n = t.size();
  for (size_t i = 0; i < n;) {
    size_t eol = t.find('\n', i);
    if (eol == std::string::npos) eol = n;
    size_t k = i;
    while (k < eol && t[k] == ' ') ++k;
    const int indent = static_cast<int>(k - i);
    bool empty = true;
    for (size_t p = k; p < eol; ++p) empty = empty && space(t[p]);
    if (block_scalar >= 0 && (empty || indent > block_scalar)) {
      i = eol + 1;
      continue;
    }
    block_scalar = -1;
    if (empty || (quote == 0 && t[k] == '#')) {
      i = eol + 1;
      continue;
    }
    if (quote == 0 && flow == 0) {
      while (!indents.empty() && indents.back() >= indent) indents.pop_back();
      indents.push_back(indent);
    }
    const int base = 2 * static_cast<int>(indents.size());
    int compact = 0;
    if (base > max_depth) return at(t, k);
    char prev = ' ';
    for (size_t p = k; p < eol; ++p) {
      const char c = t[p];
      if (quote == '\'') {
        if (c == '\'') {
          if (p + 1 < eol && t[p + 1] == '\'') ++p;  // '' is an escaped quote
          else quote = 0;
        }
        prev = c;
        continue;
      }
      if (quote == '"') {
        if (c == '\\') ++p;
        else if (c == '"') quote = 0;
        prev = c;
        continue;
      }
      const bool after_sep = space(prev) || prev == '[' || prev == '{' || prev == ',';
      if (c == '#' && space(prev)) break;  // comment
      if ((c == '"' || c == '\'') && (after_sep || prev == ':')) {
        quote = c;
      } else if (c == '[' || c == '{') {
        ++flow;
        if (base + compact + flow > max_depth) return at(t, p);
      } else if (c == ']' || c == '}') {
        if (flow > 0) --flow;
      } else if (flow == 0 && (c == '-' || c == '?' || c == ':') && (p + 1 == eol || space(t[p + 1])) &&
                 (c == ':' || space(prev))) {
        ++compact;
        if (base + compact + flow > max_depth) return at(t, p);
      } else if (flow == 0 && (c == '|' || c == '>') && space(prev)) {
        size_t q = p + 1;
        while (q < eol && (std::isdigit(static_cast<unsigned char>(t[q])) || t[q] == '+' || t[q] == '-')) ++q;
        while (q < eol && space(t[q])) ++q;
        if (q == eol || t[q] == '#') {
          block_scalar = indent;
          break;
        }
      }
      prev = c;
    }
    i = eol + 1;
  }
  return {};
}

DepthExceeded xml_depth_exceeds(const std::string& t, int max_depth) {
  int depth = 0;
  const size_t n = t.size();
  auto skip_to = [&](size_t from, const char* end) {
    const size_t e = t.find(end, from);
    return e == std::string::npos ? n : e + std::strlen(end);
  };
  for (size_t i = t.find('<'); i < n; i = t.find('<', i)) {
    if (t.compare(i, 4, "<!--") == 0) i = skip_to(i + 4, "-->");
    else if (t.compare(i, 9, "<![CDATA[") == 0) i = skip_to(i + 9, "]]>");
    else if (t.compare(i, 2, "<?") == 0) i = skip_to(i + 2, "?>");
    else if (t.compare(i, 2, "<!") == 0) i = skip_to(i + 2, ">");
    else if (t.compare(i, 2, "</") == 0) {
      if (depth > 0) --depth;
      i = skip_to(i + 2, ">");
    } else {
      size_t p = i + 1;
      char q = 0;
      for (; p < n; ++p) {
        const char c = t[p];
        if (q) {
          if (c == q) q = 0;
        } else if (c == '"' || c == '\'') {
          q = c;
        } else if (c == '>') {
          break;
        }
      }
      if (p >= n) break;  // unterminated tag: the parser reports it
      if (t[p - 1] != '/' && ++depth > max_depth) return at(t, i);
      i = p + 1;
    }
  }
  return {};
}

}  // namespace coopdyn::text

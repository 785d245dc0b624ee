#include "clients/cli/text.h"

#include <cstdio>

namespace coopdyn::cli {

// Only characters the shell passes as they are stay unquoted.
std::string shell_quote(const std::string& s) {
  if (s.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-+=./:,@%") == std::string::npos &&
      !s.empty())
    return s;
  std::string o = "'";
  for (const char c : s) o += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return o + "'";
}

std::string json_string(const std::string& s) {
  std::string o = "\"";
  for (size_t i = 0; i < s.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(s[i]);
    if (c == '"' || c == '\\') {
      o += '\\';
      o += static_cast<char>(c);
    } else if (c < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", c);
      o += buf;
    } else if (c == '/' && i > 0 && s[i - 1] == '<') {
      o += "\\/";
    } else {
      o += static_cast<char>(c);
    }
  }
  return o + "\"";
}

}  // namespace coopdyn::cli

// Bounded text input for the loaders (service config, scene and robot files, URDF): a size limit
// before anything is read into memory, a nesting pre-scan before a recursive parser sees the text
// (yaml-cpp stops at 500 levels with the message "bad file"; TinyXML, under urdfdom, has no limit
// and overflows the stack at ~50,000 nested elements), and error messages that never echo more
// than a short piece of a user's value. No dependencies: used by coopdyn_scene and coopdyn_runtime.
#pragma once

#include <cstddef>
#include <string>

namespace coopdyn::text {

inline constexpr size_t kMaxConfigBytes = 1u << 20;  // 1 MiB: the shipped config is 2 kB
inline constexpr size_t kMaxYamlBytes = 4u << 20;    // 4 MiB per scene or robot file (shipped: < 10 kB)
inline constexpr size_t kMaxUrdfBytes = 4u << 20;    // 4 MiB per URDF (a 100-link robot is ~100 kB)
inline constexpr int kMaxYamlDepth = 64;             // shipped files nest at most 6 levels
inline constexpr int kMaxXmlDepth = 32;              // URDF nests 5 (robot/link/visual/geometry/mesh)
inline constexpr size_t kMaxShownChars = 80;         // of one quoted value in an error message
// of a whole error message: room for two file paths of PATH_MAX (4096) each, printed whole and
// unquoted ("PATH:LINE: reason": the scene file and a URDF or robot file it names), and the reason
inline constexpr size_t kMaxMessageChars = 10000;

// `value` if it has at most max_chars characters, else its first and last characters around "..."
// (max_chars in all; the end is kept because a path's file name is there). Never splits a UTF-8
// character.
std::string shown(const std::string& value, size_t max_chars = kMaxShownChars);

// msg with every quoted run ('...' or "...") longer than kMaxShownChars shortened by shown(), and
// the whole message cut to kMaxMessageChars (" ... (N more characters)"), whatever its quoting.
// File paths are written unquoted by the loaders, so they stay whole; values echoed from a file are
// quoted, so they stay short.
std::string cut_values(const std::string& msg);

// Reads a regular file of at most max_bytes into *out. On failure returns false and sets *why to
// the reason, with `noun` naming the file: "cannot open NOUN (No such file or directory)", "NOUN is
// not a regular file", "NOUN is 5000000 bytes, more than the limit of 4194304". A FIFO or a device
// (/dev/zero) is refused, never read.
bool read_file(const std::string& path, size_t max_bytes, const std::string& noun, std::string* out, std::string* why);

// Where a text nests deeper than allowed: line and column 1-based, the depth estimate reached.
struct DepthExceeded {
  bool exceeded = false;
  int line = 0, column = 0;
};

// YAML: an upper bound of the nesting depth (flow [ and { levels, block indentation levels and
// compact "- ", "? ", ": " indicators on a line; quoted scalars, comments and block scalars are
// skipped). Never below the real depth, so a text that passes cannot nest deeper than max_depth
// levels; it can overestimate by about one level per line, never cumulatively.
DepthExceeded yaml_depth_exceeds(const std::string& text, int max_depth = kMaxYamlDepth);

// XML: element nesting depth (comments, CDATA, processing instructions, declarations and quoted
// attribute values skipped).
DepthExceeded xml_depth_exceeds(const std::string& text, int max_depth = kMaxXmlDepth);

}  // namespace coopdyn::text

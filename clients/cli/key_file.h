// --key-file of coopdyn send, track and control: the daemon's auth key (service/io/transport/auth.h: the same
// file format and permission check as auth.key_file), and signing what they publish with it.
#pragma once

#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "service/io/transport/auth.h"

namespace coopdyn::cli {

constexpr const char* kKeyFileHelp =
    "sign what is published with this key (the daemon's auth.key_file: 64 hex digits, mode 0600)";

// Reads --key-file if given. Returns 0, or 2 after printing why the file cannot be used.
inline int load_cli_key(const std::optional<std::string>& path, const char* cmd, std::optional<io::AuthKey>* key) {
  if (!path) return 0;
  try {
    *key = io::read_key_file(*path);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "coopdyn %s: --key-file %s\n", cmd, e.what());
    return 2;
  }
  return 0;
}

// Signs an encoded message for channel when there is a key.
inline void sign_if(std::vector<uint8_t>& msg, const std::optional<io::AuthKey>& key, const std::string& channel,
                    io::MessageType t) {
  if (key) io::sign(msg, channel, *key, t);
}

}  // namespace coopdyn::cli

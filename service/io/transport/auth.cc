#include "service/io/transport/auth.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

#include "service/io/codec/wire.h"

namespace coopdyn::io {

namespace {

int hex_digit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

std::string mode_text(mode_t m) {
  char b[8];
  std::snprintf(b, sizeof b, "%04o", static_cast<unsigned>(m & 07777));
  return b;
}

void put_i32(uint8_t* p, int32_t v) {
  const uint32_t u = static_cast<uint32_t>(v);
  p[0] = static_cast<uint8_t>(u >> 24);
  p[1] = static_cast<uint8_t>(u >> 16);
  p[2] = static_cast<uint8_t>(u >> 8);
  p[3] = static_cast<uint8_t>(u);
}

void init_sodium() {
  if (sodium_init() < 0) throw std::runtime_error("libsodium could not be initialised");
}

}  // namespace

AuthKey parse_key(const std::string& text, const std::string& name) {
  std::string t = text;
  if (!t.empty() && t.back() == '\n') t.pop_back();
  if (!t.empty() && t.back() == '\r') t.pop_back();
  if (t.size() != 2 * kKeyBytes)
    throw KeyError(name + ": not a key: expected " + std::to_string(2 * kKeyBytes) + " hex digits (" +
                   std::to_string(kKeyBytes) + " bytes) and at most a newline, found " + std::to_string(t.size()) +
                   " characters (make one with: head -c 32 /dev/urandom | xxd -p -c 64 > " + name + ")");
  AuthKey k{};
  for (int i = 0; i < kKeyBytes; ++i) {
    const int hi = hex_digit(t[2 * i]), lo = hex_digit(t[2 * i + 1]);
    if (hi < 0 || lo < 0)
      throw KeyError(name + ": not a key: character " + std::to_string(hi < 0 ? 2 * i + 1 : 2 * i + 2) +
                     " is not a hex digit (the key is 64 hex digits)");
    k[static_cast<size_t>(i)] = static_cast<uint8_t>(16 * hi + lo);
  }
  return k;
}

namespace {

const char* file_kind(mode_t m) {
  if (S_ISDIR(m)) return "a directory";
  if (S_ISFIFO(m)) return "a FIFO (named pipe)";
  if (S_ISSOCK(m)) return "a socket";
  if (S_ISCHR(m)) return "a character device";
  if (S_ISBLK(m)) return "a block device";
  return "not a regular file";
}

}  // namespace

AuthKey read_key_file(const std::string& path) {
  // O_NONBLOCK: a FIFO (or a device) opens at once instead of waiting for a writer; it is refused
  // after the fstat below, before anything is read. Symlinks are followed (a secrets volume's files
  // are symlinks); what they lead to is checked.
  const int fd = open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK | O_NOCTTY);
  if (fd < 0) throw KeyError(path + ": cannot open the key file: " + std::strerror(errno));
  struct stat st {};
  if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    const std::string kind = file_kind(st.st_mode);
    close(fd);
    throw KeyError(path + ": the key file is " + kind + ", not a regular file (64 hex digits)");
  }
  if (st.st_mode & 077) {
    close(fd);
    throw KeyError(path + ": the key file is readable or writable by group or others (mode " + mode_text(st.st_mode) +
                   "); anyone who reads it can command the daemon: chmod 600 " + path);
  }
  constexpr long long kMaxBytes = 4096;  // a key is 64 hex digits and a newline; larger is not read
  if (st.st_size > kMaxBytes) {
    close(fd);
    throw KeyError(path + ": not a key: expected " + std::to_string(2 * kKeyBytes) + " hex digits (" +
                   std::to_string(kKeyBytes) + " bytes) and at most a newline, found " +
                   std::to_string(static_cast<long long>(st.st_size)) + " bytes");
  }
  char buf[kMaxBytes + 1];
  size_t n = 0;
  for (;;) {  // to the end of the file, a short read or an interrupted one continued
    const ssize_t r = read(fd, buf + n, sizeof buf - n);
    if (r < 0 && errno == EINTR) continue;
    if (r < 0) {
      const int e = errno;
      close(fd);
      sodium_memzero(buf, sizeof buf);
      throw KeyError(path + ": cannot read the key file: " + std::strerror(e));
    }
    if (r == 0 || (n += static_cast<size_t>(r)) == sizeof buf) break;
  }
  close(fd);
  std::string text(buf, n);
  sodium_memzero(buf, sizeof buf);
  try {
    const AuthKey k = parse_key(text, path);
    sodium_memzero(text.data(), text.size());
    return k;
  } catch (...) {
    sodium_memzero(text.data(), text.size());
    throw;
  }
}

Verifier::Verifier(const AuthKey& key, const std::string& channel, MessageType t) : type_(t) {
  init_sodium();
  crypto_auth_hmacsha256_init(&prefix_, key.data(), key.size());
  crypto_auth_hmacsha256_update(&prefix_, reinterpret_cast<const unsigned char*>(channel.c_str()), channel.size() + 1);
}

Reject Verifier::check(const void* data, int len) const {
  const int at = mac_field_offset(type_, data, len);
  if (at < 0) return Reject::kDecode;
  wire::Reader r(data, len);
  int32_t mac_len = 0;
  if (!r.skip(at) || !r.i32(&mac_len)) return Reject::kDecode;
  const long long rest = static_cast<long long>(len) - at - 4;
  if (mac_len == 0) return rest == 0 ? Reject::kUnauthenticated : Reject::kDecode;
  if (mac_len != kMacBytes || rest != kMacBytes) return Reject::kBadMac;
  const auto* bytes = static_cast<const unsigned char*>(data);
  crypto_auth_hmacsha256_state st = prefix_;  // a copy: the key's and the channel's part done once
  unsigned char mac[kMacBytes];
  crypto_auth_hmacsha256_update(&st, bytes, static_cast<unsigned long long>(at));
  crypto_auth_hmacsha256_final(&st, mac);
  return sodium_memcmp(mac, bytes + at + 4, kMacBytes) == 0 ? Reject::kNone : Reject::kBadMac;
}

void sign(std::vector<uint8_t>& msg, const std::string& channel, const AuthKey& key, MessageType t) {
  init_sodium();
  const int len = static_cast<int>(msg.size());
  const int at = mac_field_offset(t, msg.data(), len);
  if (at < 0 || at + 4 != len || msg[at] | msg[at + 1] | msg[at + 2] | msg[at + 3])
    throw std::invalid_argument("sign: not an unsigned encoded message of its type");
  crypto_auth_hmacsha256_state st;
  crypto_auth_hmacsha256_init(&st, key.data(), key.size());
  crypto_auth_hmacsha256_update(&st, reinterpret_cast<const unsigned char*>(channel.c_str()), channel.size() + 1);
  crypto_auth_hmacsha256_update(&st, msg.data(), static_cast<unsigned long long>(at));
  msg.resize(static_cast<size_t>(len + kMacBytes));
  put_i32(msg.data() + at, kMacBytes);
  crypto_auth_hmacsha256_final(&st, msg.data() + at + 4);
}

int64_t raw_utime(const void* data, int len) {
  wire::Reader r(data, len);
  int64_t u = 0;
  return r.skip(8) && r.i64(&u) ? u : 0;
}

}  // namespace coopdyn::io

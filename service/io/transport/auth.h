// Authenticated inputs: a shared key, an HMAC-SHA256 in the message, checked before decoding.
//
// The MAC travels as the last fields of torque_command_t, measured_state_t and control_t
// (`int32_t mac_len; byte mac[mac_len]`): 0 = unsigned, 32 = HMAC-SHA256 (libsodium) under the
// key of the channel's name, a NUL, then the encoded message up to the mac_len field (its 8-byte
// type fingerprint included). The receiver verifies the raw bytes as they arrived, without
// re-encoding; a sender signs by encoding with mac_len 0, dropping those 4 bytes, computing the
// MAC and appending mac_len = 32 and the MAC (sign() below; clients/python/examples/live_client.py
// does the same in pure Python). The channel is covered, so a message signed for one channel fails
// on any other (another daemon's, or the control channel).
//
// The key file: 64 hex digits (32 bytes), one optional trailing newline, nothing else; a regular
// file neither readable nor writable by group or others (mode & 077 == 0). A symlink is followed
// and what it leads to checked (a Kubernetes secret volume's files are symlinks: give the volume
// defaultMode 0400). A FIFO, directory or device is refused without waiting for it. Make one with
//   head -c 32 /dev/urandom | xxd -p -c 64 > coopdyn.key; chmod 600 coopdyn.key
//
// Verifier::check runs on the receive thread for every input: no allocation, no exception, no log.
#pragma once

#include <sodium.h>

#include <array>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "service/io/codec/codec.h"
#include "service/io/codec/messages.h"

namespace coopdyn::io {

constexpr int kMacBytes = crypto_auth_hmacsha256_BYTES;  // 32
constexpr int kKeyBytes = 32;

using AuthKey = std::array<uint8_t, kKeyBytes>;

// A key file that cannot be used: the message names the file and says why.
class KeyError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Reads and checks a key file (above); a relative path is the caller's to resolve (the daemon: against
// its config file's folder). Throws KeyError naming the file and what is wrong, without blocking.
AuthKey read_key_file(const std::string& path);
// The key in a key file's text; name is the file, for the message. Throws KeyError.
AuthKey parse_key(const std::string& text, const std::string& name);

class Verifier {
 public:
  // Inputs of type t on channel, signed with key.
  Verifier(const AuthKey& key, const std::string& channel, MessageType t);
  // kNone: signed, MAC good. kUnauthenticated: mac_len 0. kBadMac: a MAC that does not verify,
  // or a mac_len other than 0 or 32. kDecode: not a message of this type (no mac_len field where
  // it must be, or bytes after the MAC).
  Reject check(const void* data, int len) const;

 private:
  MessageType type_;
  crypto_auth_hmacsha256_state prefix_;  // the key and the channel's name (and its NUL) absorbed
};

// Clients: msg is an encoded message of type t with mac_len 0 (what the encoders of codec.h make);
// replaces its mac_len by 32 and appends the MAC. Throws std::invalid_argument if msg is not
// such a message.
void sign(std::vector<uint8_t>& msg, const std::string& channel, const AuthKey& key, MessageType t);

// The utime of an encoded input (the 8 bytes after the fingerprint, as every input type starts);
// 0 if too short.
int64_t raw_utime(const void* data, int len);

}  // namespace coopdyn::io

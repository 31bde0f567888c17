// Message authentication (protocol/README.md section 8b; docs/reliability.md section 4): a
// per-run secret key, made by the launcher and given to both processes out of band (a file
// readable by the run's user only, named by $COSIM_RUN_KEY_FILE), never sent on the bus.
// Every message carries a trailer after its LCM encoding: HMAC-SHA-256 (OpenSSL) over the
// channel name, a NUL byte and the encoded bytes, 32 bytes. A message whose trailer does not
// verify is refused before it is decoded and counted as foreign (the token is public: any
// process on the bus can read it from one datagram; the key is not).
//
// Without a key (tests on memq://, outside peers started by hand) messages carry no trailer
// and nothing is verified; runs started by launch/run-coupled.sh always have one.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace cosim::protocol {

inline constexpr std::size_t kMacBytes = 32;  ///< HMAC-SHA-256
inline constexpr std::size_t kKeyBytes = 32;  ///< the launcher's key: 32 random bytes
/// The environment variable naming the key file (the launcher sets it for both servers).
inline constexpr const char* kKeyFileVariable = "COSIM_RUN_KEY_FILE";

using RunKey = std::array<std::uint8_t, kKeyBytes>;
using Mac = std::array<std::uint8_t, kMacBytes>;

/// Reads a key file: 64 hexadecimal digits (the 32 bytes), an optional newline, nothing
/// else; the file must be a regular file readable by its owner only (mode 0600 or 0400).
/// @throws std::invalid_argument with one line naming the file, what is wrong and what is
///         allowed.
RunKey read_key_file(const std::string& path);

/// The key named by $COSIM_RUN_KEY_FILE, none when the variable is unset or empty.
/// @throws std::invalid_argument as read_key_file (the variable's name in the line).
std::optional<RunKey> key_from_environment();

/// HMAC-SHA-256 under `key` of `channel`, a NUL byte and the `size` bytes at `data`.
Mac message_mac(const RunKey& key, const std::string& channel, const void* data, std::size_t size);

/// Appends the MAC of `bytes` (on `channel`) to them.
void append_mac(const RunKey& key, const std::string& channel, std::vector<std::uint8_t>& bytes);

/// The size of the message before its trailer when the trailer of the `size` bytes at
/// `data` verifies under `key` (compared in constant time); none otherwise (too short, or
/// another key, or changed bytes).
std::optional<std::size_t> verified_size(const RunKey& key, const std::string& channel, const void* data,
                                         std::size_t size);

}  // namespace cosim::protocol

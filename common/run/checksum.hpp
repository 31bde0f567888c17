// The checksum of a checkpoint's datasets and attributes (protocol/README.md section 10):
// 64 bits, FNV-1a over 8-byte little-endian words (then the tail bytes, then the length), so
// that a multi-GiB population array is checked at memory speed. Each step h -> (h ^ w) * P
// is a bijection of h for a fixed word w, so any change of one word (a flipped bit, a
// zeroed block's first word) always changes the result; it is a guard against corruption,
// not against forgery.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>

namespace cosim::protocol {

class Checksum {
 public:
  Checksum& add(const void* data, std::size_t n) {
    const auto* p = static_cast<const unsigned char*>(data);
    std::size_t k = 0;
    for (; k + 8 <= n; k += 8) {
      std::uint64_t w = 0;
      std::memcpy(&w, p + k, 8);  // the files are little-endian, as is every host we build for
      h_ = (h_ ^ w) * kPrime;
    }
    for (; k < n; ++k) h_ = (h_ ^ p[k]) * kPrime;
    length_ += n;
    return *this;
  }
  Checksum& add(const std::string& s) { return add(s.data(), s.size()); }

  /// The value, the length folded in (so that a truncated array differs too).
  std::uint64_t value() const { return (h_ ^ length_) * kPrime; }
  /// 16 lowercase hex digits.
  std::string hex() const {
    char s[17];
    std::snprintf(s, sizeof s, "%016llx", static_cast<unsigned long long>(value()));
    return s;
  }

 private:
  static constexpr std::uint64_t kPrime = 0x100000001b3ULL;
  std::uint64_t h_ = 0xcbf29ce484222325ULL;
  std::uint64_t length_ = 0;
};

}  // namespace cosim::protocol

#include "protocol/message_auth.hpp"

#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/hmac.h>
#include <sys/stat.h>

#include <cerrno>
#include <cstdlib>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <stdexcept>

namespace cosim::protocol {

namespace {

int hex_digit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

RunKey read_key(const std::string& path, const std::string& origin) {
  const auto bad = [&](const std::string& what) {
    return std::invalid_argument(origin + "\"" + path + "\": " + what);
  };
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) throw bad(std::string("cannot read it: ") + std::strerror(errno));
  if (!S_ISREG(st.st_mode)) throw bad("not a regular file; allowed: a key file written by launch/run-coupled.sh");
  if ((st.st_mode & 077) != 0) {
    char mode[8];
    std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(st.st_mode & 07777));
    throw bad(std::string("mode ") + mode + " lets others read it; allowed: readable by its owner only (chmod 600)");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw bad("cannot open it");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (!text.empty() && text.back() == '\n') text.pop_back();
  if (text.size() != 2 * kKeyBytes)
    throw bad(std::to_string(text.size()) + " characters; allowed: " + std::to_string(2 * kKeyBytes) +
              " hexadecimal digits (the 32-byte key) and a newline");
  RunKey key{};
  for (std::size_t k = 0; k < kKeyBytes; ++k) {
    const int hi = hex_digit(text[2 * k]), lo = hex_digit(text[2 * k + 1]);
    if (hi < 0 || lo < 0) throw bad("character " + std::to_string(2 * k + (hi < 0 ? 1 : 2)) + " is not a hexadecimal digit");
    key[k] = static_cast<std::uint8_t>(hi * 16 + lo);
  }
  return key;
}

}  // namespace

RunKey read_key_file(const std::string& path) { return read_key(path, "key file "); }

std::optional<RunKey> key_from_environment() {
  const char* v = std::getenv(kKeyFileVariable);
  if (v == nullptr || *v == '\0') return std::nullopt;
  return read_key(v, std::string(kKeyFileVariable) + " = ");
}

Mac message_mac(const RunKey& key, const std::string& channel, const void* data, std::size_t size) {
  Mac mac{};
  // HMAC over channel || NUL || bytes: a message cannot be moved to another channel.
  static EVP_MAC* const algorithm = EVP_MAC_fetch(nullptr, "HMAC", nullptr);  // fetched once, kept
  EVP_MAC_CTX* ctx = algorithm != nullptr ? EVP_MAC_CTX_new(algorithm) : nullptr;
  char digest[] = "SHA256";
  const OSSL_PARAM params[] = {OSSL_PARAM_construct_utf8_string("digest", digest, 0), OSSL_PARAM_construct_end()};
  std::size_t out = 0;
  const unsigned char nul = 0;
  const bool ok = ctx != nullptr && EVP_MAC_init(ctx, key.data(), key.size(), params) == 1 &&
                  EVP_MAC_update(ctx, reinterpret_cast<const unsigned char*>(channel.data()), channel.size()) == 1 &&
                  EVP_MAC_update(ctx, &nul, 1) == 1 &&
                  EVP_MAC_update(ctx, static_cast<const unsigned char*>(data), size) == 1 &&
                  EVP_MAC_final(ctx, mac.data(), &out, mac.size()) == 1 && out == mac.size();
  EVP_MAC_CTX_free(ctx);
  if (!ok) throw std::runtime_error("OpenSSL: HMAC-SHA-256 is not available");
  return mac;
}

void append_mac(const RunKey& key, const std::string& channel, std::vector<std::uint8_t>& bytes) {
  const Mac mac = message_mac(key, channel, bytes.data(), bytes.size());
  bytes.insert(bytes.end(), mac.begin(), mac.end());
}

std::optional<std::size_t> verified_size(const RunKey& key, const std::string& channel, const void* data,
                                         std::size_t size) {
  if (size < kMacBytes) return std::nullopt;
  const std::size_t n = size - kMacBytes;
  const Mac mac = message_mac(key, channel, data, n);
  if (CRYPTO_memcmp(mac.data(), static_cast<const std::uint8_t*>(data) + n, kMacBytes) != 0) return std::nullopt;
  return n;
}

}  // namespace cosim::protocol

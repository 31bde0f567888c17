/* The prescribed plate's message authentication (protocol/README.md section 8b): HMAC-SHA-256
 * under the run's key, over the channel, a NUL byte and the message's bytes. */
#define _POSIX_C_SOURCE 200809L

#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/hmac.h>

#include "plate.h"

/* ---- message authentication (protocol/README.md section 8b) ---- */


/* HMAC-SHA-256 under the run's key of the channel, a NUL byte and the message's bytes. */
int message_mac(const Plate *p, const char *channel, const void *data, size_t len, unsigned char out[MAC_BYTES]) {
  const size_t head = strlen(channel) + 1;
  unsigned char *text = malloc(head + len);
  unsigned int out_len = 0;
  if (!text) return 0;
  memcpy(text, channel, head); /* the channel and its NUL */
  if (len) memcpy(text + head, data, len);
  const int ok = HMAC(EVP_sha256(), p->key, (int)sizeof p->key, text, head + len, out, &out_len) != NULL &&
                 out_len == MAC_BYTES;
  free(text);
  return ok;
}

/* The message's length before its MAC when the run has a key and the MAC verifies (the
   whole length without a key); -1 otherwise: counted as foreign, never read. */
int verified_length(Plate *p, const lcm_recv_buf_t *rbuf, const char *channel, int index) {
  if (!p->keyed) return (int)rbuf->data_size;
  unsigned char mac[MAC_BYTES];
  if (rbuf->data_size >= MAC_BYTES &&
      message_mac(p, channel, rbuf->data, rbuf->data_size - MAC_BYTES, mac) &&
      CRYPTO_memcmp(mac, (const unsigned char *)rbuf->data + rbuf->data_size - MAC_BYTES, MAC_BYTES) == 0)
    return (int)(rbuf->data_size - MAC_BYTES);
  ++p->foreign[index];
  if (p->unauthenticated++ == 0)
    fprintf(stderr, "prescribed-plate: a message on %s whose MAC does not verify under the run's key (ignored, counted as foreign)\n",
            channel);
  return -1;
}

/* Publishes `len` encoded bytes at `bytes` (with MAC_BYTES spare after them, where the MAC goes). */
int publish_signed(Plate *p, const char *channel, unsigned char *bytes, int len) {
  if (len < 0) return -1;
  if (p->keyed) {
    if (!message_mac(p, channel, bytes, (size_t)len, bytes + len)) return -1;
    len += MAC_BYTES;
  }
  return lcm_publish(p->lcm, channel, bytes, (unsigned int)len);
}

/* The key file: 64 hexadecimal digits and a newline, readable by its owner only. */
int read_key(Plate *p, const char *path, char *why, size_t why_size) {
  struct stat st;
  if (stat(path, &st) != 0 || !S_ISREG(st.st_mode)) {
    snprintf(why, why_size, "COSIM_RUN_KEY_FILE = \"%s\": not a readable regular file", path);
    return 0;
  }
  if (st.st_mode & 077) {
    snprintf(why, why_size, "COSIM_RUN_KEY_FILE = \"%s\": mode %04o lets others read it; allowed: readable by its owner only",
             path, (unsigned)(st.st_mode & 07777));
    return 0;
  }
  FILE *f = fopen(path, "r");
  char text[80] = {0};
  const size_t n = f ? fread(text, 1, sizeof text - 1, f) : 0;
  if (f) fclose(f);
  size_t len = n;
  if (len && text[len - 1] == '\n') --len;
  int ok = len == 2 * sizeof p->key;
  for (size_t k = 0; ok && k < sizeof p->key; ++k) {
    unsigned v;
    ok = isxdigit((unsigned char)text[2 * k]) && isxdigit((unsigned char)text[2 * k + 1]) &&
         sscanf(text + 2 * k, "%2x", &v) == 1;
    p->key[k] = (unsigned char)v;
  }
  if (!ok) {
    snprintf(why, why_size, "COSIM_RUN_KEY_FILE = \"%s\": allowed: 64 hexadecimal digits (the 32-byte key) and a newline", path);
    return 0;
  }
  p->keyed = 1;
  return 1;
}

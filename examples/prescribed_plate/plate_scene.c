/* The prescribed plate's scene reader: a line-based reader of the few keys it needs (one
 * "key = value" per line), the scene's hash and the channel prefix and LCM URL rules. */
#define _POSIX_C_SOURCE 200809L

#include <ctype.h>
#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "plate.h"

static char *trim(char *s) {
  while (isspace((unsigned char)*s)) ++s;
  char *e = s + strlen(s);
  while (e > s && isspace((unsigned char)e[-1])) *--e = '\0';
  return s;
}

int parse_number(const char *v, double *out) {
  char *end = NULL;
  errno = 0;
  const double x = strtod(v, &end);
  if (end == v || errno != 0 || !isfinite(x)) return 0;
  while (isspace((unsigned char)*end)) ++end;
  if (*end != '\0') return 0;
  *out = x;
  return 1;
}

static int parse_integer(const char *v, long lo, long hi, long *out) {
  char *end = NULL;
  errno = 0;
  const long x = strtol(v, &end, 10);
  if (end == v || errno != 0 || x < lo || x > hi) return 0;
  while (isspace((unsigned char)*end)) ++end;
  if (*end != '\0') return 0;
  *out = x;
  return 1;
}

static int parse_string(const char *v, char *out) {
  const size_t n = strlen(v);
  if (n < 2 || v[0] != '"' || v[n - 1] != '"' || n - 2 >= TEXT) return 0;
  memcpy(out, v + 1, n - 2);
  out[n - 2] = '\0';
  return strchr(out, '"') == NULL && strchr(out, '\\') == NULL;
}

/* "[a, b, c]" with 1..max numbers. */
static int parse_array(const char *v, double *out, int max, int *count) {
  const size_t n = strlen(v);
  if (n < 2 || v[0] != '[' || v[n - 1] != ']' || n >= TEXT) return 0;
  char buf[TEXT];
  memcpy(buf, v + 1, n - 2);
  buf[n - 2] = '\0';
  *count = 0;
  for (char *item = strtok(buf, ","); item; item = strtok(NULL, ",")) {
    if (*count == max || !parse_number(trim(item), &out[*count])) return 0;
    ++*count;
  }
  return *count > 0;
}

static int scene_error(const char *path, int line, const char *key, const char *value, const char *what) {
  fprintf(stderr, "prescribed-plate: %s:%d: %s = %s: %s\n", path, line, key, value, what);
  return EXIT_BAD_INPUT;
}

/* Reads the few keys this solid needs; every other line is left unread. */
int read_scene(const char *path, Scene *s) {
  FILE *f = fopen(path, "r");
  if (!f) {
    fprintf(stderr, "prescribed-plate: %s: cannot read the scene file: %s\n", path, strerror(errno));
    return EXIT_BAD_INPUT;
  }
  char section[TEXT] = "", raw[4096];
  int line = 0, status = 0;
  while (status == 0 && fgets(raw, sizeof raw, f)) {
    ++line;
    int in_string = 0; /* cut the comment: '#' outside a string */
    for (char *p = raw; *p; ++p) {
      if (*p == '"') in_string = !in_string;
      if (*p == '#' && !in_string) { *p = '\0'; break; }
    }
    char *l = trim(raw);
    if (*l == '\0') continue;
    if (l[0] == '[') {
      const int array = l[1] == '[';
      char *name = trim(l + 1 + array);
      char *close = strchr(name, ']');
      if (close) *close = '\0';
      snprintf(section, sizeof section, "%s", trim(name));
      if (array && strcmp(section, "sheet") == 0) ++s->sheets;
      continue;
    }
    char *eq = strchr(l, '=');
    if (!eq) continue;
    *eq = '\0';
    const char *key = trim(l), *value = trim(eq + 1);
    long i = 0;
    double x = 0.0;
    int n = 0;
    if (strcmp(section, "grid") == 0 && strcmp(key, "dx_um") == 0) {
      if (!parse_number(value, &s->dx_um) || s->dx_um <= 0.0)
        status = scene_error(path, line, key, value, "a number > 0 (micrometres per cell) is allowed");
    } else if (strcmp(section, "output") == 0 && strcmp(key, "directory") == 0) {
      if (!parse_string(value, s->output_dir)) status = scene_error(path, line, key, value, "a quoted string is allowed");
    } else if (strcmp(section, "coupling") == 0) {
      if (strcmp(key, "time_ratio") == 0) {
        if (!parse_integer(value, 1, 1000000, &i)) status = scene_error(path, line, key, value, "an integer 1 to 1000000 is allowed");
        s->time_ratio = (int32_t)i;
      } else if (strcmp(key, "handshake_timeout_s") == 0 || strcmp(key, "peer_timeout_s") == 0 ||
                 strcmp(key, "resend_after_s") == 0) {
        if (!parse_number(value, &x) || x <= 0.0 || x > 86400.0)
          status = scene_error(path, line, key, value, "a number in (0, 86400] seconds is allowed");
        *(key[0] == 'h' ? &s->handshake_timeout_s : key[0] == 'p' ? &s->peer_timeout_s : &s->resend_after_s) = x;
      } else if (strcmp(key, "lcm_url") == 0) {
        if (!parse_string(value, s->lcm_url)) status = scene_error(path, line, key, value, "a quoted string is allowed");
      } else if (strcmp(key, "scheme") == 0) {
        /* This solid speaks the serial scheme only (protocol/README.md 5; 13 and 14 are others). */
        char scheme[TEXT];
        if (!parse_string(value, scheme) || strcmp(scheme, "serial") != 0)
          status = scene_error(path, line, key, value, "\"serial\" only (this example speaks the serial scheme)");
      } else if (strcmp(key, "channel_prefix") == 0) {
        if (!parse_string(value, s->channel_prefix)) status = scene_error(path, line, key, value, "a quoted string is allowed");
      }
    } else if (strcmp(section, "sheet") == 0 && s->sheets == 1) {
      if (strcmp(key, "nx_cg") == 0 || strcmp(key, "ny_cg") == 0) {
        if (!parse_integer(value, 1, 65536, &i)) status = scene_error(path, line, key, value, "an integer 1 to 65536 is allowed");
        *(key[1] == 'x' ? &s->nx_cg : &s->ny_cg) = i;
      } else if (strcmp(key, "spacing_um") == 0) {
        if (parse_number(value, &x)) s->spacing_um[0] = s->spacing_um[1] = x;
        else if (!parse_array(value, s->spacing_um, 2, &n) || n != 2) s->spacing_um[0] = -1.0;
        if (!(s->spacing_um[0] > 0.0 && s->spacing_um[1] > 0.0))
          status = scene_error(path, line, key, value, "a number > 0 or [width, height] > 0 is allowed");
      } else if (strcmp(key, "base_um") == 0) {
        if (!parse_array(value, s->base_um, 3, &n) || n != 3)
          status = scene_error(path, line, key, value, "[x, y, z], finite numbers on one line, is allowed");
      } else if (strcmp(key, "theta_deg") == 0) {
        if (!parse_number(value, &s->theta_deg)) status = scene_error(path, line, key, value, "a finite number is allowed");
      }
    }
  }
  fclose(f);
  if (status == 0 && s->sheets == 0) {
    fprintf(stderr, "prescribed-plate: %s: no [[sheet]]: the plate is the first [[sheet]]\n", path);
    status = EXIT_BAD_INPUT;
  }
  if (status == 0 && !(s->resend_after_s < s->peer_timeout_s)) {
    fprintf(stderr, "prescribed-plate: %s: [coupling] resend_after_s = %g must be below peer_timeout_s = %g\n", path,
            s->resend_after_s, s->peer_timeout_s);
    status = EXIT_BAD_INPUT;
  }
  return status;
}

/* protocol/README.md section 6: FNV-1a 64 of the file's bytes, 16 lowercase hex digits. */
int scene_hash(const char *path, char out[17]) {
  FILE *f = fopen(path, "rb");
  if (!f) return 0;
  uint64_t h = 0xcbf29ce484222325ULL;
  for (int b; (b = fgetc(f)) != EOF;) h = (h ^ (uint64_t)(unsigned char)b) * 0x100000001b3ULL;
  const int ok = !ferror(f);
  fclose(f);
  snprintf(out, 17, "%016" PRIx64, h);
  return ok;
}

/* protocol/README.md section 2: 1 to 32 characters from A-Z a-z 0-9 _. */
int valid_prefix(const char *p) {
  const size_t n = strlen(p);
  if (n < 1 || n > 32) return 0;
  for (size_t k = 0; k < n; ++k)
    if (!isalnum((unsigned char)p[k]) && p[k] != '_') return 0;
  return 1;
}

/* A decimal number at p of 1 to `digits` digits, no sign, no leading zero (but "0"), at most
 * `max`; its end in *end, or 0. */
static int decimal(const char *p, int digits, long max, long *out, const char **end) {
  int n = 0;
  long v = 0;
  while (isdigit((unsigned char)p[n]) && n <= digits) v = 10 * v + (p[n++] - '0');
  if (n == 0 || n > digits || (n > 1 && p[0] == '0') || v > max) return 0;
  *out = v;
  *end = p + n;
  return 1;
}

/* protocol/README.md section 1, the rule both servers apply (protocol/lcm_url.hpp): exactly
 * "memq://", or "udpm://A.B.C.D:PORT?ttl=0" with A.B.C.D an IPv4 multicast group (224.0.0.0
 * to 239.255.255.255), PORT 1 to 65535, and ttl=0 the whole query (no second ttl, no other
 * item), so that no packet leaves this machine. */
int valid_url(const char *u) {
  if (strcmp(u, "memq://") == 0) return 1;
  if (strncmp(u, "udpm://", 7) != 0) return 0;
  const char *p = u + 7;
  long part[4], port;
  for (int k = 0; k < 4; ++k) {
    if (!decimal(p, 3, 255, &part[k], &p)) return 0;
    if (*p++ != (k < 3 ? '.' : ':')) return 0;
  }
  if (part[0] < 224 || part[0] > 239) return 0;
  if (!decimal(p, 5, 65535, &port, &p) || port == 0) return 0;
  return strcmp(p, "?ttl=0") == 0;
}

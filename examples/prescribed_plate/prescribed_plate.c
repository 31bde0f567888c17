/* A second solid server for the coupled run, in C11, written from protocol/README.md alone:
 * a rigid rectangular plate of markers moved by a PRESCRIBED oscillation along the
 * stream-wise x direction. It does not react to the fluid; over each LB interval it gives the
 * fluid the momentum-exchange impulse of protocol/README.md section 5,
 *   J_l = sum over the A_T substeps of g_l dA / A_T,  g_l = 2 rho_l (U_B - u_l),
 * at X_l, the plate's mean position over the interval, and at the end it prints the mean drag
 * on the plate, -sum_l J_l per LB step.
 *
 *   prescribed_plate SCENE.toml [--output DIR] [--channel-prefix P] [--token T] [--lcm-url U]
 *                    [--amplitude A_LB] [--period STEPS] [--quiet]
 *
 * The token comes from --token or the environment variable COSIM_RUN_TOKEN (the launcher's).
 * The run's key (protocol/README.md section 8b) from the file named by COSIM_RUN_KEY_FILE:
 * with it every message out carries HMAC-SHA-256 over its channel, a NUL and its bytes,
 * appended, and a message in whose MAC does not verify is counted as foreign and dropped.
 * From the scene it reads only: the first [[sheet]] (nx_cg, ny_cg, spacing_um, base_um,
 * theta_deg), [grid] dx_um, [output] directory and [coupling] (time_ratio,
 * handshake_timeout_s, peer_timeout_s, resend_after_s, lcm_url, channel_prefix, scheme: "serial"
 * only), with a
 * line-based reader (one "key = value" per line). Exit codes: protocol/README.md section 9.
 */
#define _POSIX_C_SOURCE 200809L

#include <errno.h>
#include <float.h>
#include <inttypes.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cosim_version.h" /* the project's version and commit, generated at build time */
#include <sys/stat.h>
#include <time.h>

#include <lcm/lcm.h>

#include "cosimlcm_fluid_state_t.h"
#include "cosimlcm_hello_t.h"
#include "cosimlcm_resend_t.h"
#include "cosimlcm_solid_state_t.h"
#include "cosimlcm_stop_t.h"
#include "cosimlcm_welcome_t.h"
#include "plate.h"

/* The air of the paper's Table 1 (protocol/README.md section 4). */
static const double kSoundSpeed_m_s = 331.5;
static const double kAirNumberDensity_m3 = 2.687e25;
static const double kAirMoleculeMass_kg = 4.851e-26;
static const double kPi = 3.14159265358979323846;

/* ---------------------------------------------------------------------- the server --- */

static double now_s(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static void sleep_s(double s) {
  struct timespec t = {(time_t)s, (long)((s - floor(s)) * 1e9)};
  nanosleep(&t, NULL);
}

/* publish_T(p, channel, m): encodes a message of type T and publishes it signed. */
#define DEFINE_PUBLISH(T)                                                                  \
  static int publish_##T(Plate *p, const char *channel, const T *m) {                      \
    const int size = T##_encoded_size(m);                                                  \
    unsigned char *bytes = malloc((size_t)size + MAC_BYTES);                               \
    const int rc = bytes ? publish_signed(p, channel, bytes, T##_encode(bytes, 0, size, m)) : -1; \
    free(bytes);                                                                           \
    return rc;                                                                             \
  }
DEFINE_PUBLISH(cosimlcm_hello_t)
DEFINE_PUBLISH(cosimlcm_stop_t)
DEFINE_PUBLISH(cosimlcm_resend_t)

static int own_token(Plate *p, const char *token, int channel, const char *name) {
  if (token && strcmp(token, p->token) == 0) return 1;
  if (p->foreign[channel]++ == 0)
    fprintf(stderr, "prescribed-plate: a message with another run's token on %s (ignored, counted)\n", name);
  return 0;
}

static void fail(Plate *p, int code, const char *fmt, ...) {
  if (p->fatal) return;
  va_list args;
  va_start(args, fmt);
  vsnprintf(p->fatal_reason, sizeof p->fatal_reason, fmt, args);
  va_end(args);
  p->fatal = code;
}

static void on_welcome(const lcm_recv_buf_t *rbuf, const char *channel, void *user) {
  Plate *p = user;
  cosimlcm_welcome_t m;
  memset(&m, 0, sizeof m);
  const int len = verified_length(p, rbuf, channel, 0);
  if (len < 0) return;
  if (cosimlcm_welcome_t_decode(rbuf->data, 0, len, &m) < 0) { ++p->undecodable; return; }
  if (own_token(p, m.token, 0, channel) && !p->welcomed) { /* later copies repeat the first */
    p->welcomed = 1;
    p->accepted = m.accepted != 0;
    snprintf(p->refusal, sizeof p->refusal, "%s", m.reason ? m.reason : "");
    p->total_steps = m.total_steps;
    p->rigid_steps = m.rigid_steps;
    p->welcome_time_ratio = m.time_ratio;
  }
  cosimlcm_welcome_t_decode_cleanup(&m);
}

static void on_fluid_state(const lcm_recv_buf_t *rbuf, const char *channel, void *user) {
  Plate *p = user;
  cosimlcm_fluid_state_t m;
  memset(&m, 0, sizeof m);
  const int len = verified_length(p, rbuf, channel, 1);
  if (len < 0) return;
  if (cosimlcm_fluid_state_t_decode(rbuf->data, 0, len, &m) < 0) { ++p->undecodable; return; }
  if (!own_token(p, m.token, 1, channel) || !p->accepted) goto done;
  if (m.seq > p->fluid_seq_next) p->gap = 1; /* a lost message */
  if (m.seq >= p->fluid_seq_next) p->fluid_seq_next = m.seq + 1;
  if (m.step < p->awaited || (m.step == p->awaited && p->have_sample)) {
    if (m.step == p->awaited - 1 || m.step == p->awaited) ++p->duplicate; else ++p->stale;
    goto done;
  }
  if (m.step > p->awaited) { ++p->early; p->gap = 1; goto done; }
  /* The awaited step, first copy: check it as the coordinator checks ours (section 5). */
  if (m.num_cgps != p->n) {
    fail(p, EXIT_BAD_INPUT, "step %" PRId64 ": fluid_state_t.num_cgps: expected %d, received %d", m.step, p->n, m.num_cgps);
    goto done;
  }
  for (int32_t l = 0; l < p->n; ++l) {
    int finite = isfinite(m.rho_lb[l]);
    for (int d = 0; d < 3; ++d) finite = finite && isfinite(m.velocity_lb[l][d]);
    if (!finite || m.rho_lb[l] <= 0.0) {
      fail(p, EXIT_UNHEALTHY, "step %" PRId64 ": fluid_state_t at CGP %d: rho_lb = %g, velocity_lb = (%g, %g, %g): a finite sample with rho > 0 expected",
           m.step, l, m.rho_lb[l], m.velocity_lb[l][0], m.velocity_lb[l][1], m.velocity_lb[l][2]);
      goto done;
    }
    p->rho[l] = m.rho_lb[l];
    for (int d = 0; d < 3; ++d) p->u[l][d] = m.velocity_lb[l][d];
  }
  p->have_sample = 1;
  p->gap = 0;
done:
  cosimlcm_fluid_state_t_decode_cleanup(&m);
}

static void on_resend(const lcm_recv_buf_t *rbuf, const char *channel, void *user) {
  Plate *p = user;
  cosimlcm_resend_t m;
  memset(&m, 0, sizeof m);
  const int len = verified_length(p, rbuf, channel, 2);
  if (len < 0) return;
  if (cosimlcm_resend_t_decode(rbuf->data, 0, len, &m) < 0) { ++p->undecodable; return; }
  /* Our own requests (what = "fluid_state") come back on this channel too. */
  if (own_token(p, m.token, 2, channel) && m.what && strcmp(m.what, "solid_state") == 0) {
    ++p->resend_requests;
    for (int k = 0; k < 2; ++k) /* a step not published yet is ignored: it comes when ready */
      if (p->sent[k].bytes && p->sent[k].step == m.step) {
        if (lcm_publish(p->lcm, p->ch_solid, p->sent[k].bytes, (unsigned int)p->sent[k].len) != 0)
          fail(p, EXIT_SYSTEM, "step %" PRId64 ": cannot publish on %s", m.step, p->ch_solid);
        ++p->resends_answered;
      }
  }
  cosimlcm_resend_t_decode_cleanup(&m);
}

static void on_stop(const lcm_recv_buf_t *rbuf, const char *channel, void *user) {
  Plate *p = user;
  cosimlcm_stop_t m;
  memset(&m, 0, sizeof m);
  const int len = verified_length(p, rbuf, channel, 3);
  if (len < 0) return;
  if (cosimlcm_stop_t_decode(rbuf->data, 0, len, &m) < 0) { ++p->undecodable; return; }
  /* Our own copies come back on the bus; only the coordinator ends a run with success, and
     only at its last step (section 8): anything else with exit code 0 is not applied. */
  const int own = m.sender && strcmp(m.sender, "solid") == 0;
  const int fits = m.exit_code != 0 || (m.sender && strcmp(m.sender, "fluid") == 0 && p->welcomed &&
                                        m.step == p->total_steps && p->awaited >= p->total_steps);
  if (own_token(p, m.token, 3, channel) && !own && fits && !p->stopped) {
    p->stopped = 1;
    p->stop_code = m.exit_code;
    snprintf(p->stop_reason, sizeof p->stop_reason, "%s", m.reason ? m.reason : "");
  }
  cosimlcm_stop_t_decode_cleanup(&m);
}

static int publish_hello(Plate *p, const char *hash, double dx_m, double rho_air) {
  cosimlcm_hello_t m;
  memset(&m, 0, sizeof m);
  m.token = (char *)p->token;
  m.role = "solid";
  m.model = "prescribed-plate";
  m.version = "3"; /* protocol/README.md */
  m.scene_hash = (char *)hash;
  m.scheme = "serial"; /* the only scheme this solid runs (section 6) */
  m.dx_m = dx_m;
  m.dt_lb_s = p->dt_lb_s;
  m.sound_speed_m_s = kSoundSpeed_m_s;
  m.air_density_kg_m3 = rho_air;
  m.time_ratio = p->time_ratio;
  m.dt_cg_s = p->dt_cg_s;
  m.stable_dt_cg_s = DBL_MAX; /* no dynamics, no stability limit (section 3) */
  m.num_cgps = p->n;
  m.light_cgp_mass_kg = 0.0; /* prescribed motion: no inertia for the fluid to move (section 6) */
  m.light_cgp_area_m2 = 0.0;
  return publish_cosimlcm_hello_t(p, p->ch_hello, &m) == 0;
}

/* stop_t three times, 20 ms apart (section 8). */
static void publish_stop(Plate *p, int32_t code, const char *reason) {
  cosimlcm_stop_t m = {(char *)p->token, "solid", p->awaited > 0 ? p->awaited - 1 : 0, code, (char *)reason};
  for (int k = 0; k < 3; ++k) {
    if (k) sleep_s(0.02);
    publish_cosimlcm_stop_t(p, p->ch_stop, &m);
  }
}

static void publish_resend(Plate *p) {
  cosimlcm_resend_t m = {(char *)p->token, p->awaited, "fluid_state"};
  if (publish_cosimlcm_resend_t(p, p->ch_resend, &m) == 0) ++p->resends_asked;
}

/* Position of the plate's x offset at motion time t (LB steps) and its velocity. */
static double offset_lb(const Plate *p, double t) { return p->amplitude * sin(p->omega * t); }
static double velocity_lb(const Plate *p, double t) { return p->amplitude * p->omega * cos(p->omega * t); }

/* Section 5: one LB interval on the frozen sample of step m, then solid_state_t(m). Step 0
 * (no sample) has the initial positions and zero impulses. */
static int publish_solid_state(Plate *p, int64_t m) {
  const int32_t n = p->n;
  double(*X)[3] = calloc((size_t)n, sizeof *X), (*J)[3] = calloc((size_t)n, sizeof *J);
  double **xrow = calloc((size_t)n, sizeof *xrow), **jrow = calloc((size_t)n, sizeof *jrow);
  if (!X || !J || !xrow || !jrow) { fail(p, EXIT_SYSTEM, "step %" PRId64 ": out of memory", m); goto done; }
  int32_t substeps = 0;
  double x_mean = 0.0, u_mean = 0.0; /* the plate's x offset and velocity over the interval */
  if (m >= 1 && m >= p->rigid_steps) {
    /* Dynamic: A_T substeps. The sample is frozen and U_B is the same for every marker, so
     * sum_k 2 rho (U_B(k) - u) dA / A_T = 2 rho (mean_k U_B(k) - u) dA; U_B(k) is taken at the
     * substep's middle, X_l is the trapezoid mean over the A_T + 1 substep boundaries. */
    substeps = p->time_ratio;
    const double t0 = (double)p->substeps_total / p->time_ratio;
    for (int32_t k = 0; k <= substeps; ++k) {
      const double t = t0 + (double)k / substeps;
      x_mean += (k == 0 || k == substeps ? 0.5 : 1.0) * offset_lb(p, t) / substeps;
      if (k < substeps) u_mean += velocity_lb(p, t + 0.5 / substeps) / substeps;
    }
    p->substeps_total += substeps;
  }
  /* Spin-up (m < R): held at the initial positions, U_B = 0, J = -2 rho u dA. */
  double *drag = p->drag[m];
  for (int32_t l = 0; l < n; ++l) {
    X[l][0] = p->x0[l][0] + x_mean;
    X[l][1] = p->x0[l][1];
    X[l][2] = p->x0[l][2];
    if (m >= 1)
      for (int d = 0; d < 3; ++d) {
        J[l][d] = 2.0 * p->rho[l] * ((d == 0 ? u_mean : 0.0) - p->u[l][d]) * p->dA;
        drag[d] -= J[l][d];
      }
    xrow[l] = X[l];
    jrow[l] = J[l];
  }
  /* iteration 0: this example speaks the serial scheme only (protocol/README.md 13). */
  cosimlcm_solid_state_t msg = {(char *)p->token, p->solid_seq, m, 0, substeps,
                                (double)p->substeps_total * p->dt_cg_s, n, xrow, jrow};
  const int size = cosimlcm_solid_state_t_encoded_size(&msg);
  SentMessage *slot = &p->sent[p->solid_seq % 2]; /* keep the last two for resends */
  free(slot->bytes);
  slot->bytes = malloc((size_t)size + MAC_BYTES);
  slot->step = m;
  int len = slot->bytes ? cosimlcm_solid_state_t_encode(slot->bytes, 0, size, &msg) : -1;
  /* signed once, kept signed: a resend republishes the same bytes */
  if (len >= 0 && p->keyed && !message_mac(p, p->ch_solid, slot->bytes, (size_t)len, slot->bytes + len)) len = -1;
  if (len >= 0 && p->keyed) len += MAC_BYTES;
  slot->len = len > 0 ? (size_t)len : 0;
  if (len < 0 || lcm_publish(p->lcm, p->ch_solid, slot->bytes, (unsigned int)len) != 0)
    fail(p, EXIT_SYSTEM, "step %" PRId64 ": cannot publish solid_state_t on %s", m, p->ch_solid);
  ++p->solid_seq;
  p->awaited = m + 1;
done:
  free(X), free(J), free(xrow), free(jrow);
  return !p->fatal;
}

/* Markers of the first [[sheet]] as a rigid plate (scenes/README.md): base_um is the middle of
 * the bottom row on the wall, nx_cg across the width w = (cos theta, 0, -sin theta), ny_cg up
 * y; normal n = (sin theta, 0, cos theta). Lattice coordinates: X / dx + (0, -1/2, 0). */
static int build_plate(Plate *p, const Scene *s) {
  p->n = (int32_t)(s->nx_cg * s->ny_cg);
  p->x0 = calloc((size_t)p->n, sizeof *p->x0);
  if (!p->x0) return 0;
  const double th = s->theta_deg * kPi / 180.0;
  const double w[3] = {cos(th), 0.0, -sin(th)};
  const double hw = s->spacing_um[0] > 0.0 ? s->spacing_um[0] : s->dx_um;
  const double hh = s->spacing_um[1] > 0.0 ? s->spacing_um[1] : s->dx_um;
  p->dA = hw * hh / (s->dx_um * s->dx_um);
  for (long j = 0; j < s->ny_cg; ++j)
    for (long i = 0; i < s->nx_cg; ++i) {
      double *x = p->x0[j * s->nx_cg + i];
      const double a = ((double)i - 0.5 * (double)(s->nx_cg - 1)) * hw;
      for (int d = 0; d < 3; ++d) x[d] = (s->base_um[d] + a * w[d] + (d == 1 ? (double)j * hh : 0.0)) / s->dx_um;
      x[1] -= 0.5;
    }
  return 1;
}

static int mkdir_p(const char *dir) {
  char path[TEXT];
  snprintf(path, sizeof path, "%s", dir);
  for (char *c = path + 1; *c; ++c)
    if (*c == '/') {
      *c = '\0';
      if (mkdir(path, 0755) != 0 && errno != EEXIST) return 0;
      *c = '/';
    }
  return mkdir(path, 0755) == 0 || errno == EEXIST;
}

/* OUTPUT/plate_drag.csv: -sum_l J_l per published step; the mean over steps 1.. on stdout. */
static int finish(Plate *p, const char *output_dir, int code) {
  const int64_t last = p->awaited - 1;
  double mean[3] = {0.0, 0.0, 0.0};
  for (int64_t m = 1; m <= last; ++m)
    for (int d = 0; d < 3; ++d) mean[d] += p->drag[m][d] / (double)last;
  printf("prescribed-plate: counters: foreign tokens %ld (welcome %ld, fluid_state %ld, resend %ld, stop %ld), "
         "duplicate %ld, stale %ld, early %ld, resends asked %ld, resend requests received %ld, answered %ld, "
         "undecodable %ld\n",
         p->foreign[0] + p->foreign[1] + p->foreign[2] + p->foreign[3], p->foreign[0], p->foreign[1], p->foreign[2],
         p->foreign[3], p->duplicate, p->stale, p->early, p->resends_asked, p->resend_requests,
         p->resends_answered, p->undecodable);
  printf("prescribed-plate: mean drag Fx = %.9e F_LB = %.9e N over %" PRId64 " LB steps (Fy = %.3e, Fz = %.3e F_LB; F_LB = %.6e N)\n",
         mean[0], mean[0] * p->force_lb_N, last, mean[1], mean[2], p->force_lb_N);
  fflush(stdout);
  char path[TEXT + 32];
  snprintf(path, sizeof path, "%s/plate_drag.csv", output_dir);
  FILE *f = mkdir_p(output_dir) ? fopen(path, "w") : NULL;
  int ok = f != NULL && fprintf(f, "step,fx_lb,fy_lb,fz_lb,fx_N\n") > 0;
  for (int64_t m = 0; ok && m <= last; ++m)
    ok = fprintf(f, "%" PRId64 ",%.17g,%.17g,%.17g,%.17g\n", m, p->drag[m][0], p->drag[m][1], p->drag[m][2],
                 p->drag[m][0] * p->force_lb_N) > 0;
  if (f && fclose(f) != 0) ok = 0;
  if (!ok) {
    fprintf(stderr, "prescribed-plate: step %" PRId64 ": cannot write %s\n", last, path);
    if (code == EXIT_DONE) code = EXIT_SYSTEM;
  }
  return code;
}

/* Ends on our own error: stop_t with the code and the reason, one line on stderr. */
static int give_up(Plate *p, const char *output_dir, int code, const char *reason) {
  char line[TEXT + 32];
  snprintf(line, sizeof line, "solid: %s", reason);
  publish_stop(p, code, line);
  code = finish(p, output_dir, code);
  fprintf(stderr, "prescribed-plate: %s\n", reason); /* the last line of the log names the reason */
  return code;
}

/* The peer's stop_t: 0 done; otherwise exit 4 with its code and reason. */
static int peer_stopped(Plate *p, const char *output_dir) {
  if (p->stop_code == 0) {
    printf("prescribed-plate: run done, %" PRId64 " LB steps (stop_t from the fluid)\n", p->awaited);
    return finish(p, output_dir, EXIT_DONE);
  }
  const int code = p->welcomed ? finish(p, output_dir, EXIT_PEER_LOST) : EXIT_PEER_LOST;
  fprintf(stderr, "prescribed-plate: step %" PRId64 ": the fluid stopped with exit code %d: %s\n",
          p->awaited > 0 ? p->awaited - 1 : 0, p->stop_code, p->stop_reason);
  return code;
}

/* A refusal: one line naming what and what is allowed (prescribed_plate --help shows the
   usage), exit status 2, as the servers refuse. */
static int usage(const char *why) {
  fprintf(stderr, "prescribed-plate: %s (prescribed_plate --help shows the usage)\n", why);
  return EXIT_BAD_INPUT;
}

static int run(int argc, char **argv) {
  const char *scene_path = NULL, *output = NULL, *prefix = NULL, *url = NULL, *token = getenv("COSIM_RUN_TOKEN");
  double amplitude = 0.1, period = 100.0;
  int quiet = 0;
  for (int k = 1; k < argc; ++k) {
    const char *a = argv[k];
    const int has_value = k + 1 < argc;
    if (strcmp(a, "--version") == 0) {
      printf("prescribed_plate %s (git %s, commit %s)%s\n", COSIM_VERSION, COSIM_GIT_DESCRIBE, COSIM_GIT_COMMIT,
             COSIM_GIT_DIRTY);
      return 0;
    }
    if (strcmp(a, "--help") == 0) {
      printf("usage: prescribed_plate SCENE.toml [--output DIR] [--channel-prefix P] [--token T] [--lcm-url U] "
             "[--amplitude A_LB] [--period STEPS] [--quiet] [--version]\n");
      return 0;
    }
    if (strcmp(a, "--quiet") == 0) quiet = 1;
    else if (strcmp(a, "--output") == 0 && has_value) output = argv[++k];
    else if (strcmp(a, "--channel-prefix") == 0 && has_value) prefix = argv[++k];
    else if (strcmp(a, "--token") == 0 && has_value) token = argv[++k];
    else if (strcmp(a, "--lcm-url") == 0 && has_value) url = argv[++k];
    else if (strcmp(a, "--amplitude") == 0 && has_value) {
      if (!parse_number(argv[++k], &amplitude)) return usage("--amplitude: a finite number (lattice units) is allowed");
    } else if (strcmp(a, "--period") == 0 && has_value) {
      if (!parse_number(argv[++k], &period) || period <= 0.0) return usage("--period: a number of LB steps > 0 is allowed");
    } else if (a[0] != '-' && !scene_path) scene_path = a;
    else {
      char why[256];
      snprintf(why, sizeof why,
               a[0] == '-' ? "option \"%.100s\": unknown, or its value is missing"
                           : "\"%.100s\": a second scene file (one SCENE.toml is allowed)",
               a);
      return usage(why);
    }
  }
  if (!scene_path) return usage("no scene file");

  Scene s = {.dx_um = 0.2561, .time_ratio = 150, .handshake_timeout_s = 120.0, .peer_timeout_s = 30.0,
             .resend_after_s = 0.5, .lcm_url = "udpm://239.255.76.67:7667?ttl=0", .channel_prefix = "COSIM_",
             .output_dir = "out/prescribed_plate", .nx_cg = 5, .ny_cg = 40, .theta_deg = 90.0};
  int status = read_scene(scene_path, &s);
  if (status) return status;
  char hash[17];
  if (!scene_hash(scene_path, hash)) {
    fprintf(stderr, "prescribed-plate: %s: cannot read the scene file\n", scene_path);
    return EXIT_BAD_INPUT;
  }
  prefix = prefix ? prefix : s.channel_prefix;
  url = url ? url : s.lcm_url;
  output = output ? output : s.output_dir;
  if (!token || !*token) return usage("no run token: give --token T or set COSIM_RUN_TOKEN");
  if (!valid_prefix(prefix)) return usage("channel prefix: 1 to 32 characters from A-Z a-z 0-9 _ are allowed");
  if (!valid_url(url)) {
    char why[TEXT + 160];
    snprintf(why, sizeof why, "LCM URL \"%s\" (--lcm-url or [coupling] lcm_url): udpm://ADDR:PORT?ttl=0 (an IPv4 "
             "multicast ADDR, ttl=0 the whole query) or memq:// is allowed", url);
    return usage(why);
  }
  if (s.nx_cg * s.ny_cg > 1000000) return usage("[[sheet]] nx_cg x ny_cg: at most 1000000 markers are allowed");

  Plate p;
  memset(&p, 0, sizeof p);
  p.token = token;
  if (getenv("COSIM_RUN_KEY_FILE") && *getenv("COSIM_RUN_KEY_FILE")) {
    char why[TEXT + 160];
    if (!read_key(&p, getenv("COSIM_RUN_KEY_FILE"), why, sizeof why)) return usage(why);
  }
  p.amplitude = amplitude;
  p.omega = 2.0 * kPi / period;
  p.time_ratio = s.time_ratio;
  snprintf(p.ch_hello, sizeof p.ch_hello, "%sHELLO", prefix);
  snprintf(p.ch_welcome, sizeof p.ch_welcome, "%sWELCOME", prefix);
  snprintf(p.ch_solid, sizeof p.ch_solid, "%sSOLID_STATE", prefix);
  snprintf(p.ch_fluid, sizeof p.ch_fluid, "%sFLUID_STATE", prefix);
  snprintf(p.ch_resend, sizeof p.ch_resend, "%sRESEND", prefix);
  snprintf(p.ch_stop, sizeof p.ch_stop, "%sSTOP", prefix);
  /* Units (section 4), computed from the scene's inputs. */
  const double dx_m = s.dx_um * 1e-6, c = sqrt(3.0) * kSoundSpeed_m_s;
  const double rho_air = kAirNumberDensity_m3 * kAirMoleculeMass_kg;
  p.dt_lb_s = dx_m / c;
  p.dt_cg_s = p.dt_lb_s / s.time_ratio;
  p.force_lb_N = rho_air * c * c * dx_m * dx_m;
  if (!build_plate(&p, &s)) return usage("out of memory");
  p.rho = calloc((size_t)p.n, sizeof *p.rho);
  p.u = calloc((size_t)p.n, sizeof *p.u);
  if (!p.rho || !p.u) return usage("out of memory");
  if (!quiet)
    fprintf(stderr,
            "prescribed-plate: scene %s (hash %s), %d x %ld markers, dA = %g dx^2, x oscillation %g dx over %g LB steps; "
            "dx %g m, dt_LB %.6e s, A_T %d; channels %s*, %s\n",
            scene_path, hash, (int)s.nx_cg, s.ny_cg, p.dA, amplitude, period, dx_m, p.dt_lb_s, s.time_ratio, prefix, url);

  p.lcm = lcm_create(url);
  if (!p.lcm) {
    fprintf(stderr, "prescribed-plate: cannot open LCM at %s\n", url);
    return EXIT_SYSTEM;
  }
  lcm_subscribe(p.lcm, p.ch_welcome, on_welcome, &p);
  lcm_subscribe(p.lcm, p.ch_fluid, on_fluid_state, &p);
  lcm_subscribe(p.lcm, p.ch_resend, on_resend, &p);
  lcm_subscribe(p.lcm, p.ch_stop, on_stop, &p);

  /* Handshake (section 6): hello_t every 200 ms until the welcome_t of this run. */
  const double t_start = now_s();
  double next_hello = t_start;
  while (!p.welcomed && !p.stopped) {
    const double t = now_s();
    if (t - t_start > s.handshake_timeout_s) {
      char why[TEXT];
      snprintf(why, sizeof why, "step 0: no welcome_t within the handshake timeout of %g s", s.handshake_timeout_s);
      fprintf(stderr, "prescribed-plate: %s\n", why);
      publish_stop(&p, EXIT_PEER_LOST, why);
      return EXIT_PEER_LOST;
    }
    if (t >= next_hello) {
      if (!publish_hello(&p, hash, dx_m, rho_air)) {
        fprintf(stderr, "prescribed-plate: cannot publish on %s\n", p.ch_hello);
        return EXIT_SYSTEM;
      }
      next_hello = t + 0.2;
    }
    const double wait = next_hello - now_s();
    if (lcm_handle_timeout(p.lcm, wait > 0.0 ? (int)ceil(1000.0 * wait) : 0) < 0) {
      fprintf(stderr, "prescribed-plate: LCM failed while waiting for welcome_t\n");
      return EXIT_SYSTEM;
    }
  }
  if (!p.welcomed) return peer_stopped(&p, output);
  if (!p.accepted) {
    fprintf(stderr, "prescribed-plate: the coordinator refused the run: %s\n", p.refusal);
    return EXIT_BAD_INPUT;
  }
  p.drag = calloc((size_t)(p.total_steps > 0 ? p.total_steps : 1), sizeof *p.drag);
  if (!p.drag) return EXIT_SYSTEM;
  if (p.total_steps < 1 || p.rigid_steps < 0 || p.welcome_time_ratio != p.time_ratio) {
    char why[TEXT];
    snprintf(why, sizeof why, "step 0: welcome_t: total_steps %" PRId64 " (>= 1 allowed), rigid_steps %" PRId64
             " (>= 0 allowed), time_ratio %d (this solid announced %d)", p.total_steps, p.rigid_steps,
             p.welcome_time_ratio, p.time_ratio);
    return give_up(&p, output, EXIT_BAD_INPUT, why);
  }
  if (!quiet)
    fprintf(stderr, "prescribed-plate: handshake accepted: %" PRId64 " LB steps, %" PRId64 " rigid, A_T %d\n",
            p.total_steps, p.rigid_steps, p.time_ratio);

  /* Lock-step (sections 5, 7, 8): solid_state_t(0), then one per fluid_state_t until stop_t. */
  publish_solid_state(&p, 0);
  double last_progress = now_s(), last_ask = last_progress, last_report = last_progress;
  for (;;) {
    if (p.fatal) return give_up(&p, output, p.fatal, p.fatal_reason);
    if (p.stopped) return peer_stopped(&p, output);
    const double t = now_s();
    if (p.have_sample) {
      if (p.awaited >= p.total_steps) {
        char why[TEXT];
        snprintf(why, sizeof why, "step %" PRId64 ": fluid_state_t beyond the run's %" PRId64 " steps", p.awaited,
                 p.total_steps);
        return give_up(&p, output, EXIT_BAD_INPUT, why);
      }
      p.have_sample = 0;
      publish_solid_state(&p, p.awaited);
      last_progress = last_ask = t;
      continue;
    }
    if (t - last_progress > s.peer_timeout_s) {
      char why[TEXT];
      snprintf(why, sizeof why, "step %" PRId64 ": the fluid was silent for %.1f s waiting for fluid_state_t(%" PRId64 ")",
               p.awaited - 1, t - last_progress, p.awaited);
      return give_up(&p, output, EXIT_PEER_LOST, why);
    }
    if (p.gap || t - last_ask >= s.resend_after_s) {
      publish_resend(&p);
      p.gap = 0;
      last_ask = t;
    }
    if (!quiet && t - last_report >= 1.0) {
      fprintf(stderr, "prescribed-plate: step %" PRId64 " / %" PRId64 "\n", p.awaited - 1, p.total_steps);
      last_report = t;
    }
    const double wait = fmin(last_ask + s.resend_after_s, last_progress + s.peer_timeout_s) - t;
    if (lcm_handle_timeout(p.lcm, wait > 0.0 ? (int)ceil(1000.0 * wait) : 0) < 0) {
      char why[TEXT];
      snprintf(why, sizeof why, "step %" PRId64 ": LCM failed while waiting for fluid_state_t", p.awaited - 1);
      return give_up(&p, output, EXIT_SYSTEM, why);
    }
  }
}

int main(int argc, char **argv) {
  /* Resources are the process's: the OS takes them back at exit. */
  return run(argc, argv);
}

/* The prescribed plate's shared types (examples/prescribed_plate): the scene it reads, the
 * server's state, and the functions of its scene reader (plate_scene.c) and of its message
 * authentication (plate_auth.c). */
#ifndef PRESCRIBED_PLATE_H
#define PRESCRIBED_PLATE_H

#include <stddef.h>
#include <stdint.h>

#include <lcm/lcm.h>

enum { EXIT_DONE = 0, EXIT_SYSTEM = 1, EXIT_BAD_INPUT = 2, EXIT_UNHEALTHY = 3, EXIT_PEER_LOST = 4 };

#define TEXT 512

enum { MAC_BYTES = 32 };

/* The scene (the few keys this server reads). */
typedef struct {
  double dx_um;
  int32_t time_ratio;
  double handshake_timeout_s, peer_timeout_s, resend_after_s;
  char lcm_url[TEXT], channel_prefix[TEXT], output_dir[TEXT];
  int sheets; /* [[sheet]] tables seen; only the first is read */
  long nx_cg, ny_cg;
  double spacing_um[2]; /* across the width, up the height; 0: dx_um */
  double base_um[3];
  double theta_deg;
} Scene;

/* The server's state. */
typedef struct {
  size_t len;
  uint8_t *bytes;
  int64_t step;
} SentMessage;

typedef struct {
  /* set up once */
  lcm_t *lcm;
  const char *token;
  char ch_hello[64], ch_welcome[64], ch_solid[64], ch_fluid[64], ch_resend[64], ch_stop[64];
  int32_t n;          /* markers */
  double (*x0)[3];    /* initial marker positions, lattice coordinates */
  double dA;          /* surface element of a marker, dx^2 */
  double amplitude;   /* of the x oscillation, dx */
  double omega;       /* 2 pi / period, per LB step */
  int32_t time_ratio; /* A_T of the scene; the welcome's must equal it */
  double dt_lb_s, dt_cg_s, force_lb_N;
  /* handshake */
  int welcomed, accepted;
  char refusal[TEXT];
  int64_t total_steps, rigid_steps;
  int32_t welcome_time_ratio;
  /* lock-step */
  int64_t awaited;        /* the fluid_state_t step waited for; last published + 1 */
  int have_sample;        /* the awaited sample arrived and waits to be used */
  double *rho, (*u)[3];   /* the frozen sample */
  int gap;                /* a seq gap or an early step: ask again now */
  int64_t fluid_seq_next; /* next fluid seq expected */
  int64_t solid_seq, substeps_total;
  SentMessage sent[2];
  /* ending */
  int stopped;
  int32_t stop_code;
  char stop_reason[TEXT];
  int fatal;
  char fatal_reason[TEXT];
  /* counters */
  long foreign[4], duplicate, stale, early, resends_asked, resend_requests, resends_answered, undecodable;
  /* -sum_l J_l of each published step, lattice force */
  double (*drag)[3];
  /* the run's key (section 8b), when COSIM_RUN_KEY_FILE names one */
  int keyed;
  unsigned char key[32];
  long unauthenticated;
} Plate;

/* plate_scene.c */
int read_scene(const char *path, Scene *s);
/* A finite number (the whole text); 0 for anything else. */
int parse_number(const char *v, double *out);
/* protocol/README.md section 6: FNV-1a 64 of the file's bytes, 16 lowercase hex digits. */
int scene_hash(const char *path, char out[17]);
/* protocol/README.md section 2: 1 to 32 characters from A-Z a-z 0-9 _. */
int valid_prefix(const char *p);
/* protocol/README.md section 1: "memq://" or "udpm://GROUP:PORT?ttl=0". */
int valid_url(const char *u);

/* plate_auth.c (protocol/README.md section 8b) */
int message_mac(const Plate *p, const char *channel, const void *data, size_t len, unsigned char out[MAC_BYTES]);
int verified_length(Plate *p, const lcm_recv_buf_t *rbuf, const char *channel, int index);
int publish_signed(Plate *p, const char *channel, unsigned char *bytes, int len);
int read_key(Plate *p, const char *path, char *why, size_t why_size);

#endif

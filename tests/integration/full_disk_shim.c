/* A full disk, injected (DiskFullLosesAtMostOneInterval): an LD_PRELOAD library whose
 * write, pwrite, pwrite64 and writev fail with ENOSPC, once COSIM_FULL_DISK_BYTES bytes in
 * all have been written, for files under COSIM_FULL_DISK_DIR (the *.log files excepted: the
 * launcher's redirections stand for a terminal), in the program COSIM_FULL_DISK_PROGRAM
 * ("fluid" or "solid"; any if unset). The disk then stays full. Portable where mounting a
 * small tmpfs is not allowed (containers, CI). With COSIM_FULL_DISK_COUNT=FILE nothing
 * fails: the bytes written in all go to FILE at exit (a clean run's volume, to size the
 * budget of the next). */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/types.h>
#include <sys/uio.h>
#include <unistd.h>

static long long limit_bytes = -1; /* -1: not initialised, -2: off */
static long long used_bytes = 0;
static char dir[PATH_MAX];
static size_t dir_length = 0;

static const char* count_file = NULL;

static void init(void) {
  if (limit_bytes != -1) return;
  const char* d = getenv("COSIM_FULL_DISK_DIR");
  const char* b = getenv("COSIM_FULL_DISK_BYTES");
  const char* p = getenv("COSIM_FULL_DISK_PROGRAM");
  if (d == NULL || b == NULL || strlen(d) >= sizeof dir) {
    limit_bytes = -2;
    return;
  }
  if (p != NULL && p[0] != '\0') {
    char comm[64] = {0};
    FILE* f = fopen("/proc/self/comm", "r");
    if (f != NULL) {
      if (fgets(comm, sizeof comm, f) == NULL) comm[0] = '\0';
      fclose(f);
    }
    comm[strcspn(comm, "\n")] = '\0';
    if (strcmp(comm, p) != 0) {
      limit_bytes = -2;
      return;
    }
  }
  strcpy(dir, d);
  dir_length = strlen(dir);
  limit_bytes = atoll(b);
  count_file = getenv("COSIM_FULL_DISK_COUNT");
  if (count_file != NULL && count_file[0] == '\0') count_file = NULL;
}

__attribute__((destructor)) static void report(void) {
  if (count_file == NULL) return;
  FILE* f = fopen(count_file, "w");
  if (f == NULL) return;
  fprintf(f, "%lld\n", __atomic_load_n(&used_bytes, __ATOMIC_SEQ_CST));
  fclose(f);
}

/* Whether a write of n bytes to fd goes through (else errno = ENOSPC). */
static int allowed(int fd, size_t n) {
  init();
  if (limit_bytes < 0) return 1;
  char link[64], path[PATH_MAX];
  snprintf(link, sizeof link, "/proc/self/fd/%d", fd);
  const ssize_t k = readlink(link, path, sizeof path - 1);
  if (k <= 0) return 1;
  path[k] = '\0';
  if (strncmp(path, dir, dir_length) != 0) return 1;
  const size_t length = strlen(path);
  if (length >= 4 && strcmp(path + length - 4, ".log") == 0) return 1;
  if (__atomic_add_fetch(&used_bytes, (long long)n, __ATOMIC_SEQ_CST) <= limit_bytes || count_file != NULL)
    return 1;
  __atomic_store_n(&used_bytes, limit_bytes + 1, __ATOMIC_SEQ_CST);
  errno = ENOSPC;
  return 0;
}

ssize_t write(int fd, const void* buf, size_t n) {
  static ssize_t (*real)(int, const void*, size_t) = NULL;
  if (real == NULL) real = (ssize_t(*)(int, const void*, size_t))dlsym(RTLD_NEXT, "write");
  if (!allowed(fd, n)) return -1;
  return real(fd, buf, n);
}

ssize_t pwrite(int fd, const void* buf, size_t n, off_t at) {
  static ssize_t (*real)(int, const void*, size_t, off_t) = NULL;
  if (real == NULL) real = (ssize_t(*)(int, const void*, size_t, off_t))dlsym(RTLD_NEXT, "pwrite");
  if (!allowed(fd, n)) return -1;
  return real(fd, buf, n, at);
}

ssize_t pwrite64(int fd, const void* buf, size_t n, off64_t at) {
  static ssize_t (*real)(int, const void*, size_t, off64_t) = NULL;
  if (real == NULL) real = (ssize_t(*)(int, const void*, size_t, off64_t))dlsym(RTLD_NEXT, "pwrite64");
  if (!allowed(fd, n)) return -1;
  return real(fd, buf, n, at);
}

ssize_t writev(int fd, const struct iovec* iov, int count) {
  static ssize_t (*real)(int, const struct iovec*, int) = NULL;
  if (real == NULL) real = (ssize_t(*)(int, const struct iovec*, int))dlsym(RTLD_NEXT, "writev");
  size_t n = 0;
  for (int k = 0; k < count; ++k) n += iov[k].iov_len;
  if (!allowed(fd, n)) return -1;
  return real(fd, iov, count);
}

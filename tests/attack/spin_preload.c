// LD_PRELOAD shim for attack tests: a card call that hangs SPINNING on a CPU (the card simulator's
// own hang, AJAR_SIM_BLOCK_FILE, sleeps). It wraps dlsym so that the driver's GT_GetSts is this
// file's wrapper: while the file named by $AJAR_SPIN_FILE exists, the first call that sees it
// busy-waits (user space, no syscall but an access() every ~100 us) until the file is removed,
// then calls the real GT_GetSts. Other threads' calls go on. Build:
//   gcc -shared -fPIC -O1 -o /tmp/spin_preload.so spin_preload.c -ldl
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

typedef short (*GetSts)(short, long*, short, unsigned long*);
static GetSts real_get_sts;
static atomic_int spinning;

static double now_s(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);  // vDSO: no syscall
  return ts.tv_sec + ts.tv_nsec * 1e-9;
}

static short spin_get_sts(short axis, long* sts, short count, unsigned long* clock) {
  const char* file = getenv("AJAR_SPIN_FILE");
  if (file && access(file, F_OK) == 0) {
    int expected = 0;
    if (atomic_compare_exchange_strong(&spinning, &expected, 1)) {
      while (access(file, F_OK) == 0) {
        const double until = now_s() + 100e-6;
        while (now_s() < until) {
        }
      }
      atomic_store(&spinning, 0);
    }
  }
  return real_get_sts(axis, sts, count, clock);
}

void* dlsym(void* handle, const char* name) {
  static void* (*real_dlsym)(void*, const char*);
  if (!real_dlsym) real_dlsym = (void* (*)(void*, const char*))dlvsym(RTLD_NEXT, "dlsym", "GLIBC_2.34");
  if (!real_dlsym) real_dlsym = (void* (*)(void*, const char*))dlvsym(RTLD_NEXT, "dlsym", "GLIBC_2.2.5");
  void* sym = real_dlsym(handle, name);
  if (sym && strcmp(name, "GT_GetSts") == 0) {
    real_get_sts = (GetSts)sym;
    return (void*)spin_get_sts;
  }
  return sym;
}

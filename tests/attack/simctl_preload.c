// LD_PRELOAD shim for attack tests: lets a script drive the card simulator's fault injection in a
// running ajard (gdb inferior calls do not work here). A thread polls $AJAR_SIMCTL (a file) every
// 5 ms; a line "FAIL fn code count" calls AjarSim_FailNextCalls, "DELAY us" AjarSim_SetCallDelayUs,
// "LAG ms" AjarSim_SetEncoderLagMs, "FAULT axis kind" AjarSim_InjectFault; the file is removed once
// applied.
#define _GNU_SOURCE
#include <dlfcn.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static void* watch(void* arg) {
  (void)arg;
  const char* path = getenv("AJAR_SIMCTL");
  const char* lib = getenv("AJAR_SIMLIB");
  if (!path || !lib) return NULL;
  for (;;) {
    usleep(5000);
    FILE* f = fopen(path, "r");
    if (!f) continue;
    char line[256];
    void* h = dlopen(lib, RTLD_NOW | RTLD_NOLOAD);
    while (h && fgets(line, sizeof line, f)) {
      char fn[64];
      int a, b;
      if (sscanf(line, "FAIL %63s %d %d", fn, &a, &b) == 3) {
        void (*p)(const char*, short, int) = dlsym(h, "AjarSim_FailNextCalls");
        if (p) p(fn, (short)a, b);
      } else if (sscanf(line, "DELAY %d", &a) == 1) {
        void (*p)(int) = dlsym(h, "AjarSim_SetCallDelayUs");
        if (p) p(a);
      } else if (sscanf(line, "LAG %d", &a) == 1) {
        void (*p)(double) = dlsym(h, "AjarSim_SetEncoderLagMs");
        if (p) p((double)a);
      } else if (sscanf(line, "FAULT %d %d", &a, &b) == 2) {
        void (*p)(int, int) = dlsym(h, "AjarSim_InjectFault");
        if (p) p(a, b);
      }
    }
    fclose(f);
    if (h) unlink(path);
  }
  return NULL;
}

__attribute__((constructor)) static void start(void) {
  pthread_t t;
  if (getenv("AJAR_SIMCTL")) pthread_create(&t, NULL, watch, NULL), pthread_detach(t);
}

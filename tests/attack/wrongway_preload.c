// LD_PRELOAD shim for attack tests: a card that runs the wrong way. It wraps dlsym so that the
// driver's GT_SetVel is this file's wrapper: while the file named by $AJAR_WRONGWAY_FILE exists,
// every GT_SetVel is passed on with its velocity negated (accepted, applied backwards). Build:
//   gcc -shared -fPIC -O1 -o /tmp/wrongway_preload.so wrongway_preload.c -ldl
// (starve_lie.py builds it and preloads it with simctl_preload.c.)
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

typedef short (*SetVel)(short, double);
static SetVel real_set_vel;

static short wrongway_set_vel(short profile, double vel) {
  const char* file = getenv("AJAR_WRONGWAY_FILE");
  if (file && access(file, F_OK) == 0) vel = -vel;
  return real_set_vel(profile, vel);
}

void* dlsym(void* handle, const char* name) {
  static void* (*real_dlsym)(void*, const char*);
  if (!real_dlsym)
    real_dlsym = (void* (*)(void*, const char*))dlvsym(RTLD_NEXT, "dlsym", "GLIBC_2.34");
  if (!real_dlsym)
    real_dlsym = (void* (*)(void*, const char*))dlvsym(RTLD_NEXT, "dlsym", "GLIBC_2.2.5");
  void* sym = real_dlsym(handle, name);
  if (sym && strcmp(name, "GT_SetVel") == 0) {
    real_set_vel = (SetVel)sym;
    return (void*)wrongway_set_vel;
  }
  return sym;
}

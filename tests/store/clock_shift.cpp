// LD_PRELOAD library for tests: the wall clock (CLOCK_REALTIME) of the processes it is loaded into runs ahead by
// the number of seconds written in the file $VARBO_TEST_CLOCK_SHIFT_FILE (read at every call), as when NTP steps
// the clock of a robot PC without a battery clock. The monotonic clocks are untouched.
#include <dlfcn.h>
#include <time.h>

#include <cstdio>
#include <cstdlib>

extern "C" __attribute__((visibility("default"))) int clock_gettime(clockid_t id, struct timespec* ts) {
  using Real = int (*)(clockid_t, struct timespec*);
  static Real real = reinterpret_cast<Real>(dlsym(RTLD_NEXT, "clock_gettime"));
  const int rc = real(id, ts);
  if (rc == 0 && (id == CLOCK_REALTIME || id == CLOCK_REALTIME_COARSE))
    if (const char* file = std::getenv("VARBO_TEST_CLOCK_SHIFT_FILE"))
      if (FILE* f = std::fopen(file, "r")) {
        long shift = 0;
        if (std::fscanf(f, "%ld", &shift) == 1) ts->tv_sec += shift;
        std::fclose(f);
      }
  return rc;
}

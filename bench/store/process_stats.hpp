#pragma once
// Shared by the store benchmarks: a process's CPU time and the median of repeated measurements.
#include <sys/resource.h>

#include <algorithm>
#include <vector>

namespace varbo::bench {

/// CPU seconds (user + system) of this process (who = RUSAGE_SELF, all threads) or of its waited-for children.
inline double cpu_seconds(int who = RUSAGE_SELF) {
  rusage u{};
  getrusage(who, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

inline double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n == 0 ? 0.0 : (n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]));
}

}  // namespace varbo::bench

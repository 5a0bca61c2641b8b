#pragma once
// Text for code that runs between fork and exec or in the supervisor (a forked child of a possibly
// multi-threaded varbo): no allocation, no locale, no stdio.

namespace varbo::tasks::signal_safe {

/// Writes the decimal digits of v ≥ 0 to `out` (room for 20 characters, no terminator); returns how many.
inline int decimal(long v, char* out) {
  char digits[20];
  int n = 0;
  do {
    digits[n++] = static_cast<char>('0' + v % 10);
    v /= 10;
  } while (v > 0 && n < 20);
  int len = 0;
  while (n > 0) out[len++] = digits[--n];
  return len;
}

}  // namespace varbo::tasks::signal_safe

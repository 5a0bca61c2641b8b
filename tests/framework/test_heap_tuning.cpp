// libvarbo_core keeps freed big blocks in glibc's heap (framework/core/src/runtime/heap_tuning.cpp): a block of a
// few MB, the size of a fit's N × N matrices, must come from the heap, not from a fresh mapping (glibc's default
// maps every block over 128 KB until its dynamic threshold has adapted).
#include <doctest/doctest.h>

#include <cstdlib>
#include <cstring>
#include <initializer_list>

#include "varbo/math.hpp"  // links libvarbo_core, whose load applies the tuning

#if defined(__GLIBC__) && !defined(__SANITIZE_ADDRESS__)
#include <malloc.h>

TEST_CASE("heap tuning: a 4 MB block comes from the heap, not from mmap") {
  const char* opt_out = std::getenv("VARBO_HEAP_TUNING");
  const char* tunables = std::getenv("GLIBC_TUNABLES");
  bool user_tuned = tunables != nullptr && std::strstr(tunables, "glibc.malloc.") != nullptr;
  for (const char* name : {"MALLOC_MMAP_THRESHOLD_", "MALLOC_TRIM_THRESHOLD_", "MALLOC_TOP_PAD_", "MALLOC_MMAP_MAX_"})
    user_tuned = user_tuned || std::getenv(name) != nullptr;
  if ((opt_out != nullptr && std::strcmp(opt_out, "0") == 0) || user_tuned) {
    MESSAGE("skipped: the heap tuning is turned off in this environment (VARBO_HEAP_TUNING=0 or malloc tuned)");
    return;
  }
  // Keep the library loaded and used (the tuning runs when it is loaded).
  CHECK(varbo::normal_cdf(0.0) == doctest::Approx(0.5));
  const struct mallinfo2 before = mallinfo2();
  void* block = std::malloc(4u << 20);
  REQUIRE(block != nullptr);
  std::memset(block, 1, 4u << 20);
  const struct mallinfo2 during = mallinfo2();
  std::free(block);
  // hblkhd: bytes in mmapped blocks. With glibc's defaults it grows by the block's 4 MB here.
  CHECK(during.hblkhd == before.hblkhd);
}
#endif

// Keeps freed big blocks in glibc's heap for every program that loads varbo (the CLI, an embedded `Study`, the
// Python module, a benchmark), so a model fit is not dominated by the allocator.
//
// Why: one evaluation of the GP log marginal likelihood allocates and frees about seven N × N matrices (K, its
// Cholesky factor, L⁻¹, K⁻¹, W = αα' − K⁻¹, ...): 320 KB each at N = 200. glibc's defaults either map such a block
// fresh (mmap threshold 128 KB until it adapts) or, once adapted, give the top of the heap back to the kernel
// whenever more than twice the block size is free (the dynamic trim threshold) — so every evaluation page-faults
// and zeroes a few MB again. Measured on the idle 2-core VM (bench_gp BM_LogPosterior, d = 6): one evaluation
// with its gradient 4.46 ms with glibc's defaults, 1.28 ms with the blocks kept at N = 200 (206 / 104 ms at
// N = 1000), and two threads made a 4-restart fit no faster than one before (docs/defaults.md, "The allocator").
// jemalloc and tcmalloc keep such blocks by design; this is the glibc equivalent.
//
// What is kept: blocks up to 64 MB come from the heap (an N × N matrix up to N ≈ 2,900), and the heap is trimmed
// only once 256 MB at its top are free. The `varbo` CLI, a short process, keeps more (framework/cli/main.cpp).
// Not applied when the user tuned malloc already (MALLOC_*_ variables or a glibc.malloc tunable) or set
// VARBO_HEAP_TUNING=0.
#include <cstdlib>
#include <cstring>
#include <initializer_list>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#if defined(__GLIBC__)
namespace {

bool user_tuned_malloc() {
  for (const char* name : {"MALLOC_MMAP_THRESHOLD_", "MALLOC_TRIM_THRESHOLD_", "MALLOC_TOP_PAD_", "MALLOC_MMAP_MAX_"})
    if (std::getenv(name) != nullptr) return true;
  const char* tunables = std::getenv("GLIBC_TUNABLES");
  return tunables != nullptr && std::strstr(tunables, "glibc.malloc.") != nullptr;
}

// A constructor function rather than a static object: it runs when the library is loaded, before any fit, in
// programs that never reference this file (a shared library keeps every object file).
__attribute__((constructor)) void keep_freed_blocks_in_heap() {
  const char* opt_out = std::getenv("VARBO_HEAP_TUNING");
  if (opt_out != nullptr && std::strcmp(opt_out, "0") == 0) return;
  if (user_tuned_malloc()) return;
  mallopt(M_MMAP_THRESHOLD, 64 << 20);
  mallopt(M_TRIM_THRESHOLD, 256 << 20);
}

}  // namespace
#endif

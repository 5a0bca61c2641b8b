// LeakSanitizer suppressions compiled into libvarbo_study (sanitizer builds only; docs/sanitizers.md).
//
// libpqxx 6.4 leaks the libpq result of a statement whose connection the server has just ended (stacks end in
// pqxx::connection_base::exec / exec_params → libpq → PQmakeEmptyPGresult: ~2 KiB per dropped connection, lost
// inside the library while it throws broken_connection; seen in test_postgres's dropped-connection case and in a
// worker that reconnects). Allocations *inside libpq* are suppressed: varbo never calls libpq itself, every libpq
// object is owned by a libpqxx object, so a leak of ours (a connection, a result, any object of our own) is still
// reported as the direct leak it is. The worker's stacks are cut short above libpqxx (no frame pointers there), so
// the one library frame cannot be named more narrowly than its module.
//
// glibc keeps the locale names it builds with argz (__argz_add_sep, under newlocale/setlocale) when a program loads
// a named locale such as de_DE.UTF-8: ~200 bytes reported as a direct leak once per process that does it (the test
// of a host that sets the global C++ locale, test_locale.cpp; session 32). varbo never calls argz itself.
// LeakSanitizer looks this hook up at exit in the executable and the libraries it was linked with.
#if defined(__SANITIZE_ADDRESS__)
extern "C" const char* __lsan_default_suppressions();
extern "C" const char* __lsan_default_suppressions() { return "leak:libpq.so\nleak:__argz_add_sep\n"; }
#endif

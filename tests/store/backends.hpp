#pragma once
// The store backends every parametrized store/study test runs on: a SQLite file, and a study in the throwaway
// PostgreSQL server of the ctest fixture `pg_server` (tests/store/pg_server.sh). Its base URL comes from
// $VARBO_TEST_PG_URL, or the file named by $VARBO_TEST_PG_URL_FILE that the fixture writes; without either the
// PostgreSQL cases fail (they are never skipped).
#include <unistd.h>

#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "varbo_test.hpp"

namespace varbo::test {

enum class Backend { Sqlite, Postgres };

inline std::vector<Backend> all_backends() { return {Backend::Sqlite, Backend::Postgres}; }
inline std::string backend_name(Backend b) { return b == Backend::Sqlite ? "sqlite" : "postgresql"; }

/// postgresql://varbo@/varbo_test?host=/tmp/varbo-pg.XXXX (no study).
inline std::string pg_base_url() {
  if (const char* u = std::getenv("VARBO_TEST_PG_URL"); u && *u) return u;
  std::string url;
  if (const char* f = std::getenv("VARBO_TEST_PG_URL_FILE"); f && *f) std::getline(std::ifstream(f), url);
  if (url.empty())
    FAIL("no PostgreSQL test server: run through ctest (fixture pg_server), or start one with "
         "tests/store/pg_server.sh start DIR and set VARBO_TEST_PG_URL_FILE=DIR/url");
  return url;
}

/// A study name no other test, process or earlier run uses.
inline std::string unique_study_name(const std::string& name) {
  static std::mt19937_64 rng(std::random_device{}());
  static int counter = 0;
  return name + "_" + std::to_string(getpid()) + "_" + std::to_string(++counter) + "_" + std::to_string(rng() % 100000);
}

inline std::string pg_study_url(const std::string& name) { return pg_base_url() + "&study=" + unique_study_name(name); }

/// A fresh study address on backend `b`: `dir/name.db`, or a new study name in the test database.
inline std::string study_address(Backend b, const std::string& dir, const std::string& name) {
  return b == Backend::Sqlite ? dir + "/" + name + ".db" : pg_study_url(name);
}

}  // namespace varbo::test

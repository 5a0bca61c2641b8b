#pragma once
// The PostgreSQL store lives in its own library, libvarbo_study_postgres.so, which libvarbo_study loads (dlopen)
// the first time a postgresql:// address is used: libpq and libpqxx pull in ~23 shared libraries (Kerberos, LDAP,
// GnuTLS, OpenSSL, SASL), whose loading cost every `varbo` process ~8 ms although most studies are SQLite files
// (docs/studies.md, "Cost of varbo suggest"). This is the table of entry points the library hands back.
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "varbo/store.hpp"

namespace varbo::detail {

/// A held `varbo run` lock on the database server (DatabaseRunLock): the lock lasts as long as this object.
struct DatabaseLockSession {
  virtual ~DatabaseLockSession() = default;
  /// Whether the session (and so the lock) still lives: one round trip.
  virtual bool alive() = 0;
};

/// Bumped whenever this table changes: a library of another build is refused with a clear message.
inline constexpr int kPostgresBackendAbi = 2;

struct PostgresBackend {
  int abi = kPostgresBackendAbi;
  std::unique_ptr<StudyStore> (*create)(const std::string& url,
                                        const std::vector<std::pair<std::string, std::string>>& meta) = nullptr;
  std::unique_ptr<StudyStore> (*open)(const std::string& url) = nullptr;
  std::unique_ptr<DatabaseLockSession> (*take_run_lock)(const std::string& url) = nullptr;
};

/// The library's entry point (extern "C", looked up by name).
inline constexpr const char* kPostgresBackendSymbol = "varbo_study_postgres_backend";
inline constexpr const char* kPostgresBackendLibrary = "libvarbo_study_postgres.so";

/// The backend, loaded on first use. `url` is the study being opened, for messages: a malformed URL is reported
/// as such first (parse_postgres_address), a library that cannot be loaded as an InputError naming the study,
/// the library and the loader's reason.
const PostgresBackend& postgres_backend(const std::string& url);

}  // namespace varbo::detail

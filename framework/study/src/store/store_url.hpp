#pragma once
// The address of a study in a PostgreSQL database: `postgresql://[user[:password]@][host][:port]/db?study=NAME[&...]`
// (docs/studies.md, "Addresses"). `study` is varbo's; every other parameter is libpq's (host=/socket/dir,
// sslmode, connect_timeout, ...).
#include <exception>
#include <string>

namespace varbo {

struct PostgresAddress {
  std::string conninfo;  ///< the URL for libpq: without `study`, with application_name and connect_timeout
  std::string study;     ///< the study's name in the database
  std::string display;   ///< the URL as given with any password hidden, for messages
};

/// Throws InputError for a URL without `?study=NAME` or with a name holding other than ASCII letters, digits, '_', '-', '.'.
PostgresAddress parse_postgres_address(const std::string& url);

/// A libpqxx error's message for ours: one line, without libpq's "FATAL:  " / "ERROR:  " prefixes.
std::string postgres_cause(const std::exception& e);

/// Whether a failed connection attempt was refused by a server that answered — wrong password, no such role or
/// database, no pg_hba.conf entry, no permission — rather than a server that is down or unreachable. A refusal is
/// final (an InputError); only an unreachable server is worth retrying (StoreConnectionError, store_retry.hpp).
bool postgres_refused(const std::exception& e);

}  // namespace varbo

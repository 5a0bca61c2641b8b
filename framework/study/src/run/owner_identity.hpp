#pragma once
// Who holds a lock, as the lock's owner line says it (run_lock.cpp for run folders, store_postgres_lock.cpp for
// database studies): this machine's name and the current UTC time.
#include <string>

namespace varbo::detail {

/// gethostname(), or "unknown".
std::string machine_name();

/// What drives the run: "varbo run" for the command line, else the program's name ("python3" for
/// `varbo.minimize`, a test binary): a second run's error names who holds the study.
std::string run_owner_program();

/// The current time as 2026-12-02T03:04:05Z.
std::string utc_timestamp();

}  // namespace varbo::detail

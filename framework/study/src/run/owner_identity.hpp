#pragma once
// Who holds a lock, as the lock's owner line says it (run_lock.cpp for run folders, store_postgres_lock.cpp for
// database studies): this machine's name and the current UTC time.
#include <string>

namespace varbo::detail {

/// gethostname(), or "unknown".
std::string machine_name();

/// The current time as 2026-12-02T03:04:05Z.
std::string utc_timestamp();

}  // namespace varbo::detail

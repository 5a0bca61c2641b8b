#pragma once
// Idle PostgreSQL connections kept by the process after a study store closes, for the next open of the same
// address. Connecting costs a new server process (~25 ms on a local socket: issue 14's measurements in
// docs/studies.md), most of a `Study::open` + `ask`; a program that reopens a study per trial pays it every
// time without this. Kept: at most one idle connection per connection string, for at most
// `VARBO_PG_KEEP_SECONDS` seconds (default 30; 0 keeps none), closed when an open or close of any study in the
// process finds it expired, and at exit. Never shared: a connection is either in a store or here. A forked child
// starts with an empty pool and never closes the parent's connections (their sockets are the parent's session).
#include <memory>
#include <pqxx/connection>
#include <string>

namespace varbo::detail {

/// The kept connection for `conninfo`, or nullptr. It may have been ended by the server meanwhile (restart,
/// pg_terminate_backend): the caller retries its first statement on a fresh connection.
std::unique_ptr<pqxx::connection> take_kept_connection(const std::string& conninfo);

/// Keeps `c` (open, outside any transaction) for the next open of `conninfo`; closes it when keeping is off.
void keep_connection(const std::string& conninfo, std::unique_ptr<pqxx::connection> c);

}  // namespace varbo::detail

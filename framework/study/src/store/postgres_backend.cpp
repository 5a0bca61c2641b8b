// Loads libvarbo_study_postgres.so on the first postgresql:// address (postgres_backend.hpp says why). It is
// looked for beside libvarbo_study.so (the build's lib/ folder, or the installed libdir), then through the
// loader's usual search (LD_LIBRARY_PATH, this library's RUNPATH). It is never unloaded: stores and locks it made
// may live until the process ends.
#include "postgres_backend.hpp"

#include <dlfcn.h>
#include <fmt/format.h>

#include <filesystem>
#include <mutex>

#include "store_url.hpp"
#include "varbo/errors.hpp"
#include "varbo/run_lock.hpp"

namespace varbo {

namespace detail {

namespace {

/// The folder holding this library (libvarbo_study.so), "" when the loader cannot say.
std::filesystem::path own_folder() {
  Dl_info info{};
  if (dladdr(reinterpret_cast<void*>(&postgres_backend), &info) == 0 || !info.dli_fname) return {};
  return std::filesystem::path(info.dli_fname).parent_path();
}

struct Loaded {
  const PostgresBackend* backend = nullptr;
  std::string error;  ///< why it could not be loaded
};

Loaded load() {
  Loaded out;
  const std::filesystem::path beside = own_folder() / kPostgresBackendLibrary;
  std::error_code ec;
  const bool found_beside = !beside.parent_path().empty() && std::filesystem::exists(beside, ec);
  const std::string name = found_beside ? beside.string() : std::string(kPostgresBackendLibrary);
  void* handle = dlopen(name.c_str(), RTLD_NOW | RTLD_LOCAL | RTLD_NODELETE);
  if (!handle) {
    const char* why = dlerror();
    out.error = fmt::format("cannot load {} ({}): PostgreSQL studies need it installed beside libvarbo_study.so",
                            name, why ? why : "unknown reason");
    return out;
  }
  using Entry = const PostgresBackend* (*)();
  auto entry = reinterpret_cast<Entry>(dlsym(handle, kPostgresBackendSymbol));
  const PostgresBackend* b = entry ? entry() : nullptr;
  if (!b || b->abi != kPostgresBackendAbi || !b->create || !b->open || !b->take_run_lock) {
    out.error = fmt::format("{} is not this varbo's PostgreSQL store (entry point {}: {}); reinstall varbo", name,
                            kPostgresBackendSymbol, !b ? "missing" : "of another version");
    return out;
  }
  out.backend = b;
  return out;
}

}  // namespace

const PostgresBackend& postgres_backend(const std::string& url) {
  const PostgresAddress address = parse_postgres_address(url);  // a malformed URL is reported as such
  static const Loaded loaded = load();                          // once per process (thread-safe static)
  if (!loaded.backend) throw InputError(fmt::format("{}: {}", address.display, loaded.error));
  return *loaded.backend;
}

}  // namespace detail

std::unique_ptr<StudyStore> create_postgres_store(const std::string& url,
                                                  const std::vector<std::pair<std::string, std::string>>& meta) {
  return detail::postgres_backend(url).create(url, meta);
}

std::unique_ptr<StudyStore> open_postgres_store(const std::string& url) {
  return detail::postgres_backend(url).open(url);
}

struct DatabaseRunLock::Session {
  std::unique_ptr<detail::DatabaseLockSession> held;
};

DatabaseRunLock DatabaseRunLock::acquire(const std::string& url) {
  auto s = std::make_unique<Session>();
  s->held = detail::postgres_backend(url).take_run_lock(url);
  return DatabaseRunLock(std::move(s));
}

DatabaseRunLock::DatabaseRunLock(std::unique_ptr<Session> session) : session_(std::move(session)) {}
DatabaseRunLock::DatabaseRunLock(DatabaseRunLock&&) noexcept = default;
DatabaseRunLock& DatabaseRunLock::operator=(DatabaseRunLock&&) noexcept = default;
DatabaseRunLock::~DatabaseRunLock() = default;
bool DatabaseRunLock::held() const { return session_ && session_->held && session_->held->alive(); }

}  // namespace varbo

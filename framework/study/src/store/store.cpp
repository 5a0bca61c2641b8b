// Backend-independent parts of the study store.
#include <fmt/format.h>
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <limits>
#include <chrono>
#include <cstdlib>
#include <random>

#include "varbo/errors.hpp"
#include "varbo/store.hpp"
#include "varbo/text.hpp"

namespace varbo {

StudyStore::~StudyStore() = default;

namespace {
// steady_clock ticks of the last lost contact; min() = never. Atomic: heartbeat threads note it too.
std::atomic<std::chrono::steady_clock::rep> g_unreachable_at{std::numeric_limits<std::chrono::steady_clock::rep>::min()};
}  // namespace

void note_store_unreachable() noexcept {
  g_unreachable_at.store(std::chrono::steady_clock::now().time_since_epoch().count(), std::memory_order_relaxed);
}

double seconds_since_store_unreachable() noexcept {
  const auto at = g_unreachable_at.load(std::memory_order_relaxed);
  if (at == std::numeric_limits<std::chrono::steady_clock::rep>::min()) return std::numeric_limits<double>::infinity();
  const auto since = std::chrono::steady_clock::now().time_since_epoch() - std::chrono::steady_clock::duration(at);
  return std::chrono::duration<double>(since).count();
}

std::string state_name(TrialState s) {
  switch (s) {
    case TrialState::Pending: return "pending";
    case TrialState::Complete: return "complete";
    case TrialState::Failed: return "failed";
    case TrialState::Abandoned: return "abandoned";
  }
  return "pending";
}

TrialState state_from_name(const std::string& n) {
  if (n == "pending") return TrialState::Pending;
  if (n == "complete") return TrialState::Complete;
  if (n == "failed") return TrialState::Failed;
  if (n == "abandoned") return TrialState::Abandoned;
  throw InputError(fmt::format("unknown trial state '{}' (expected pending, complete, failed or abandoned)", n));
}

std::string host_id() {
  if (const char* env = std::getenv("VARBO_HOST_ID"); env && *env) return env;
  char host[256] = {0};
  if (gethostname(host, sizeof(host) - 1) != 0) host[0] = 0;
  return host[0] ? host : "localhost";
}

std::string default_worker_name() { return fmt::format("{}:{}", host_id(), static_cast<long>(getpid())); }

namespace {
const char* host_origin(const std::string& given) {
  if (!given.empty()) return "";
  const char* env = std::getenv("VARBO_HOST_ID");
  return env && *env ? " (from $VARBO_HOST_ID)" : " (the machine's host name)";
}
}  // namespace

std::string new_worker_id(const std::string& host_in) {
  const std::string host = host_in.empty() ? host_id() : host_in;
  if (host.find(':') != std::string::npos || host.find_first_of(" \t\n") != std::string::npos)
    throw InputError(fmt::format("host id '{}'{}: expected a name without ':' or spaces; give one with --host-id or "
                                 "$VARBO_HOST_ID",
                                 printable(host), host_origin(host_in)));
  std::random_device rd;
  const std::uint64_t nonce = (static_cast<std::uint64_t>(rd()) << 32) ^ rd();
  return fmt::format("{}:{}:{:016x}", host, static_cast<long>(getpid()), nonce);
}

std::pair<std::string, long> worker_host_pid(const std::string& worker) {
  // host:pid or host:pid:nonce; a host name holds no ':' (an IPv6 literal would, and is not a host name here).
  const auto first = worker.find(':');
  if (first == std::string::npos) return {worker, 0};
  const auto second = worker.find(':', first + 1);
  const std::string pid = worker.substr(first + 1, second == std::string::npos ? std::string::npos : second - first - 1);
  if (pid.empty() || pid.find_first_not_of("0123456789") != std::string::npos || pid.size() > 9)
    return {worker.substr(0, first), 0};
  return {worker.substr(0, first), std::stol(pid)};
}

bool worker_process_gone(const std::string& worker) {
  const auto [host, pid] = worker_host_pid(worker);
  return host == host_id() && pid > 0 && ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH;
}

double unix_time() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

}  // namespace varbo

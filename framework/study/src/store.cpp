// Backend-independent parts of the study store.
#include <fmt/format.h>
#include <unistd.h>

#include <chrono>

#include "varbo/errors.hpp"
#include "varbo/store.hpp"

namespace varbo {

StudyStore::~StudyStore() = default;

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

std::string default_worker_name() {
  char host[256] = {0};
  if (gethostname(host, sizeof(host) - 1) != 0) host[0] = 0;
  return fmt::format("{}:{}", host[0] ? host : "localhost", static_cast<long>(getpid()));
}

double unix_time() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

}  // namespace varbo

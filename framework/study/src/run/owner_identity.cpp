#include "owner_identity.hpp"

#include <unistd.h>

#include <cerrno>
#include <ctime>

namespace varbo::detail {

std::string machine_name() {
  char host[256] = "unknown";
  if (gethostname(host, sizeof host - 1) != 0) return "unknown";
  host[sizeof host - 1] = '\0';
  return host;
}

std::string run_owner_program() {
  const std::string name = program_invocation_short_name;  // GNU: argv[0]'s last component
  if (name == "varbo") return "varbo run";
  return name.empty() ? std::string("a program") : name;
}

std::string utc_timestamp() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char when[32];
  std::strftime(when, sizeof when, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return when;
}

}  // namespace varbo::detail

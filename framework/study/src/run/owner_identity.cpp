#include "owner_identity.hpp"

#include <unistd.h>

#include <ctime>

namespace varbo::detail {

std::string machine_name() {
  char host[256] = "unknown";
  if (gethostname(host, sizeof host - 1) != 0) return "unknown";
  host[sizeof host - 1] = '\0';
  return host;
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

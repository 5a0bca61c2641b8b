#pragma once
// The HTTP server of `varbo dashboard` lives in its own library, libvarbo_dashboard_http.so, loaded only by that
// command (dashboard_server.cpp): cpp-httplib brings OpenSSL, zlib and brotli, whose loading cost every other
// `varbo` process ~3.4 ms (docs/studies.md, "Cost of varbo suggest"). This is what the command hands it.
#include <functional>
#include <string>

#include "dashboard_api.hpp"

namespace varbo::cli {

/// Bumped whenever this struct changes: a library of another build is refused with a clear message.
inline constexpr int kDashboardHttpAbi = 1;

struct DashboardHttp {
  int abi = kDashboardHttpAbi;
  std::function<ApiResponse(const std::string& path, const ApiQuery& query)> get;  ///< never throws
  std::string host;
  int port = 8080;                        ///< 0: any free port
  std::function<void(int port)> on_listening;
};

inline constexpr const char* kDashboardHttpLibrary = "libvarbo_dashboard_http.so";
inline constexpr const char* kDashboardHttpSymbol = "varbo_dashboard_http_serve";

}  // namespace varbo::cli

/// Serves until the process is stopped; InputError when the address cannot be bound.
extern "C" void varbo_dashboard_http_serve(const varbo::cli::DashboardHttp& http);

#pragma once
// The HTTP side of `varbo dashboard`: cpp-httplib (Debian's libcpp-httplib-dev, in libvarbo_dashboard_http.so,
// loaded by this function: dashboard_http.hpp) serving the page at / and the
// JSON API under /api/ (dashboard_api.hpp). Read-only: GET only.
#include <functional>
#include <string>

#include "dashboard_api.hpp"

namespace varbo::cli {

/// Serves until the process is stopped. Binds `host`:`port` (port 0: any free port); `on_listening` is called
/// with the port bound before the first request is taken. InputError when the address cannot be bound.
void serve_dashboard(DashboardApi& api, const std::string& host, int port,
                     const std::function<void(int port)>& on_listening);

}  // namespace varbo::cli

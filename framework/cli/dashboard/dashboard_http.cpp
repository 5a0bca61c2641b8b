// libvarbo_dashboard_http.so: cpp-httplib serving the page at / and the JSON API under /api/ for `varbo dashboard`
// (dashboard_http.hpp says why it is a library of its own). Read-only: GET only.
#include "dashboard_http.hpp"

#include <fmt/format.h>
#include <httplib.h>

#include "varbo/errors.hpp"

namespace varbo::cli {

namespace {
#include "dashboard_page.inc"  // kDashboardPage: dashboard_page.html, embedded at build time (dashboard.cmake)

/// As json_text (dashboard_api.cpp): invalid UTF-8 replaced.
std::string error_body(const std::string& message) {
  return nlohmann::json{{"error", message}}.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

void json_reply(httplib::Response& res, int status, const std::string& body) {
  res.status = status;
  res.set_header("Cache-Control", "no-store");
  res.set_content(body, "application/json; charset=utf-8");
}

void serve(const DashboardHttp& http) {
  const std::string& host = http.host;
  const int port = http.port;
  httplib::Server server;
  // A few threads: requests are short reads; model requests queue on the model's lock. A browser keeps up to 6
  // connections open, each holding a thread while it idles: a short keep-alive frees them for the next poll.
  server.new_task_queue = [] { return new httplib::ThreadPool(8); };
  server.set_keep_alive_timeout(1);
  server.set_default_headers({{"X-Content-Type-Options", "nosniff"},
                              {"Content-Security-Policy",
                               "default-src 'none'; script-src 'unsafe-inline'; style-src 'unsafe-inline'; "
                               "connect-src 'self'; img-src 'self' data:"},
                              {"Referrer-Policy", "no-referrer"}});
  server.Get("/", [](const httplib::Request&, httplib::Response& res) {
    res.set_header("Cache-Control", "no-store");
    res.set_content(reinterpret_cast<const char*>(kDashboardPage), sizeof(kDashboardPage) - 1, "text/html; charset=utf-8");
  });
  server.Get(R"(/api/.*)", [&http](const httplib::Request& req, httplib::Response& res) {
    ApiQuery query(req.params.begin(), req.params.end());
    const ApiResponse r = http.get(req.path, query);
    json_reply(res, r.status, r.body);
  });
  // Anything else (another path or method, a request httplib cannot parse): a JSON error, never a stack trace.
  server.set_error_handler([](const httplib::Request& req, httplib::Response& res) {
    if (!res.body.empty()) return;
    const std::string message =
        res.status == 404 ? fmt::format("no such page '{}'", req.path)
                          : fmt::format("request refused (HTTP {}); the dashboard answers GET / and GET /api/...", res.status);
    json_reply(res, res.status, error_body(message));
  });
  server.set_exception_handler([](const httplib::Request&, httplib::Response& res, std::exception_ptr ep) {
    std::string what = "internal error";
    try {
      std::rethrow_exception(ep);
    } catch (const std::exception& e) {
      what = e.what();
    } catch (...) {
    }
    json_reply(res, 500, error_body(what));
  });
  const int bound = port == 0 ? server.bind_to_any_port(host) : (server.bind_to_port(host, port) ? port : -1);
  if (bound < 0)
    throw InputError(fmt::format("--host {} --port {}: cannot listen there (in use, or not an address of this machine)",
                                 host, port));
  http.on_listening(bound);
  if (!server.listen_after_bind()) throw InputError(fmt::format("{}:{}: the server stopped unexpectedly", host, bound));
}

}  // namespace

}  // namespace varbo::cli

extern "C" __attribute__((visibility("default"))) void varbo_dashboard_http_serve(
    const varbo::cli::DashboardHttp& http) {
  varbo::cli::serve(http);
}

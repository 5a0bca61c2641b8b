// libvarbo_dashboard_http.so: cpp-httplib serving the page at / and the JSON API under /api/ for `varbo dashboard`
// (dashboard_http.hpp says why it is a library of its own). Read-only: GET only.
#include "dashboard_http.hpp"
#include "growing_pool.hpp"

#include <fmt/format.h>
#include <malloc.h>
#include <poll.h>
#include <sys/socket.h>

#include <httplib.h>

#include <atomic>
#include <cctype>
#include <chrono>
#include <thread>

#include "varbo/errors.hpp"
#include "varbo/interrupt.hpp"
#include "varbo/text.hpp"

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

/// cpp-httplib's task queue interface over GrowingPool (growing_pool.hpp says why not httplib's ThreadPool).
class GrowingTaskQueue : public httplib::TaskQueue {
 public:
  static constexpr std::size_t kMaxThreads = 128;
  void enqueue(std::function<void()> fn) override { pool_.enqueue(std::move(fn)); }
  void shutdown() override { pool_.shutdown(); }

 private:
  // Idle threads leave after 10 s; with all of them idle, the heaps the requests grew go back to the system
  // (a burst of /api/trials on a 12,000-trial study held 1.1 GB for good, red team session 29).
  GrowingPool pool_{kMaxThreads, std::chrono::seconds(10), 2, [] { malloc_trim(0); }};
};

int hex_digit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

/// %XX and '+' decoded (a malformed escape stays as it is).
std::string url_decode(const std::string& s) {
  std::string out;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '%' && i + 2 < s.size() && hex_digit(s[i + 1]) >= 0 && hex_digit(s[i + 2]) >= 0) {
      out += static_cast<char>(hex_digit(s[i + 1]) * 16 + hex_digit(s[i + 2]));
      i += 2;
    } else {
      out += s[i] == '+' ? ' ' : s[i];
    }
  }
  return out;
}

/// The query of a request target, split at '&' and at the FIRST '=' of each item. cpp-httplib 0.11 keeps the text
/// after the last '=' ("weights=a=-1" became weights → "-1", "weights==" an empty, accepted value).
ApiQuery parse_query(const std::string& target) {
  ApiQuery query;
  const std::size_t q = target.find('?');
  if (q == std::string::npos) return query;
  const std::string text = target.substr(q + 1);
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t end = std::min(text.find('&', start), text.size());
    const std::string item = text.substr(start, end - start);
    if (!item.empty()) {
      const std::size_t eq = item.find('=');
      query.emplace(url_decode(item.substr(0, eq)), eq == std::string::npos ? "" : url_decode(item.substr(eq + 1)));
    }
    start = end + 1;
  }
  return query;
}

namespace {
/// "127.0.0.1", "localhost", "::1", "[::1]" and the rest of 127.0.0.0/8: names that only reach this machine.
bool is_loopback_host(std::string h) {
  for (char& c : h) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (h == "localhost" || h == "::1" || h == "[::1]") return true;
  return h.rfind("127.", 0) == 0 && h.find_first_not_of("0123456789.") == std::string::npos;
}
/// The name of a Host header without its port: "[::1]:8080" → "[::1]", "localhost:80" → "localhost".
std::string host_name_of(const std::string& header) {
  if (!header.empty() && header[0] == '[') {
    const auto close = header.find(']');
    return close == std::string::npos ? header : header.substr(0, close + 1);
  }
  const auto colon = header.rfind(':');
  return colon == std::string::npos ? header : header.substr(0, colon);
}
}  // namespace

void serve(const DashboardHttp& http) {
  const std::string& host = http.host;
  const int port = http.port;
  httplib::Server server;
  // A few threads: requests are short reads; model requests queue on the model's lock. A browser keeps up to 6
  // connections open, each holding a thread while it idles: a short keep-alive frees them for the next poll.
  server.new_task_queue = [] { return new GrowingTaskQueue(); };
  server.set_keep_alive_timeout(1);
  // Headers and body go out as two writes: without TCP_NODELAY the second waited for the client's delayed ACK,
  // ~40 ms on every small reply of a kept-open connection, i.e. on each of the page's polls (red team, session 29).
  server.set_tcp_nodelay(true);
  server.set_read_timeout(3);  // a request that has not arrived in 3 s of silence frees its thread
  server.set_default_headers({{"X-Content-Type-Options", "nosniff"},
                              {"Content-Security-Policy",
                               "default-src 'none'; script-src 'unsafe-inline'; style-src 'unsafe-inline'; "
                               "connect-src 'self'; img-src 'self' data:"},
                              {"Referrer-Policy", "no-referrer"}});
  // DNS rebinding: a web page whose name resolves to 127.0.0.1 reads this port as its own origin, so a
  // loopback-only dashboard answers only requests addressed to a loopback name (red team, session 27: any Host
  // was served, the study readable from any site the researcher visited). Served to the network (--host 0.0.0.0,
  // ::, an interface address), the names are the user's to choose and no Host is refused.
  const bool loopback_only = is_loopback_host(host);
  server.set_pre_routing_handler([loopback_only](const httplib::Request& req, httplib::Response& res) {
    // Range requests are ignored (RFC 9110 section 14.2 lets a server send the whole representation with 200):
    // httplib cut an /api reply to the range but kept its 200, so a client got a piece of JSON marked complete,
    // and 300 overlapping ranges of the page made a 2.7 KB request send 9 MB (audit, session 48). The replies are
    // small and change between requests, so a part of one is of no use. A Range header httplib cannot parse is
    // still refused with 416 before this runs. The request is the server's own non-const object (httplib
    // parses it, then hands it to the handlers as const).
    const_cast<httplib::Request&>(req).ranges.clear();
    if (!loopback_only) return httplib::Server::HandlerResponse::Unhandled;
    const std::string name = host_name_of(req.get_header_value("Host"));
    if (name.empty() || is_loopback_host(name)) return httplib::Server::HandlerResponse::Unhandled;
    json_reply(res, 403,
               error_body(fmt::format("Host '{}' refused: this dashboard serves this machine only (open it as "
                                      "http://127.0.0.1:PORT/ or http://localhost:PORT/)",
                                      safe_text(name, 80))));
    return httplib::Server::HandlerResponse::Handled;
  });
  server.Get("/", [](const httplib::Request&, httplib::Response& res) {
    res.set_header("Cache-Control", "no-store");
    res.set_content(reinterpret_cast<const char*>(kDashboardPage), sizeof(kDashboardPage) - 1, "text/html; charset=utf-8");
  });
  server.Get(R"(/api/.*)", [&http](const httplib::Request& req, httplib::Response& res) {
    const ApiQuery query = parse_query(req.target);
    const ApiResponse r = http.get(req.path, query);
    json_reply(res, r.status, r.body);
  });
  // Every other method, on every path: 405 with the methods served (HEAD is answered as GET by httplib).
  const auto refuse = [](const httplib::Request& req, httplib::Response& res) {
    res.set_header("Allow", "GET, HEAD");
    json_reply(res, 405,
               error_body(fmt::format("method {} not allowed: the dashboard is read-only and answers GET / and GET "
                                      "/api/... only",
                                      req.method)));
  };
  server.Post(".*", refuse);
  server.Put(".*", refuse);
  server.Patch(".*", refuse);
  server.Delete(".*", refuse);
  server.Options(".*", refuse);
  // Anything else (another path or method, a request httplib cannot parse): a JSON error, never a stack trace.
  server.set_error_handler([refuse](const httplib::Request& req, httplib::Response& res) {
    if (!res.body.empty()) return;
    // httplib refuses a POST/PUT/PATCH without a body (no Content-Length) with 400 before routing: it is the method
    // that is not served, as docs/dashboard.md says (red team, session 22).
    if (res.status == 400 && (req.method == "POST" || req.method == "PUT" || req.method == "PATCH")) {
      refuse(req, res);
      return;
    }
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
  // SO_REUSEADDR only (a port in TIME_WAIT after a restart is fine). httplib's default is SO_REUSEPORT, which let
  // a second dashboard bind the port a first one serves: both ran, and the kernel split the requests between two
  // studies (docs/dashboard.md promises "a port in use: a message naming it, exit 2").
  socket_t listening = INVALID_SOCKET;  // the last socket made: the one bound, when binding succeeds
  server.set_socket_options([&listening](socket_t sock) {
    int yes = 1;
    ::setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
    listening = sock;
  });
  const int bound = port == 0 ? server.bind_to_any_port(host) : (server.bind_to_port(host, port) ? port : -1);
  if (bound < 0)
    throw InputError(fmt::format("--host {} --port {}: cannot listen there (in use, or not an address of this machine)",
                                 host, port));
  // Debian's libcpp-httplib is compiled with a listen backlog of 5: of 40 connections opened at once, ~30 waited
  // a second for the client's SYN retry, and a connect-close loop met that second every ~8 connections (red team,
  // session 29). Listening again on a listening socket sets its backlog (Linux listen(2)).
  int accepting = 0;
  socklen_t size = sizeof accepting;
  if (listening != INVALID_SOCKET && ::getsockopt(listening, SOL_SOCKET, SO_ACCEPTCONN, &accepting, &size) == 0 &&
      accepting != 0)
    ::listen(listening, 128);
  http.on_listening(bound);
  // SIGINT, SIGTERM, SIGHUP (varbo's one-shot handlers, installed by the command): stop accepting, finish the
  // requests in flight, and return, so that the study is closed (SQLite removes the -wal/-shm files it made beside
  // a run's study.db; the default action left them there). A second signal kills at once.
  std::atomic<bool> done{false};
  std::thread watcher([&] {
    pollfd fd{interrupt_fd(), POLLIN, 0};
    while (!done.load()) {
      if (fd.fd < 0) return;
      // Until listen returns: a signal that came before the server was running would find nothing to stop.
      if (::poll(&fd, 1, 200) > 0 && interrupt_signal() != 0) {
        server.stop();
        std::this_thread::sleep_for(std::chrono::milliseconds(100));  // the pipe stays readable: no busy loop
      }
    }
  });
  const bool ok = server.listen_after_bind();
  done = true;
  watcher.join();
  if (const int sig = interrupt_signal(); sig != 0) throw Interrupted(sig);
  if (!ok) throw InputError(fmt::format("{}:{}: the server stopped unexpectedly", host, bound));
}

}  // namespace

}  // namespace varbo::cli

extern "C" __attribute__((visibility("default"))) void varbo_dashboard_http_serve(
    const varbo::cli::DashboardHttp& http) {
  varbo::cli::serve(http);
}

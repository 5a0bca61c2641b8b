// serve_dashboard: loads libvarbo_dashboard_http.so (dashboard_http.hpp says why it is separate) from beside the
// varbo libraries (the build's lib/ folder, or the installed libdir), else through the loader's search, and hands
// it the API. Only `varbo dashboard` comes here.
#include "dashboard_server.hpp"

#include <dlfcn.h>
#include <fmt/format.h>

#include <filesystem>

#include "dashboard_http.hpp"
#include "varbo/errors.hpp"
#include "varbo/store.hpp"

namespace varbo::cli {

namespace {
/// The folder holding libvarbo_study.so, "" when the loader cannot say.
std::filesystem::path library_folder() {
  Dl_info info{};
  if (dladdr(reinterpret_cast<void*>(&varbo::open_store), &info) == 0 || !info.dli_fname) return {};
  return std::filesystem::path(info.dli_fname).parent_path();
}
}  // namespace

void serve_dashboard(DashboardApi& api, const std::string& host, int port,
                     const std::function<void(int port)>& on_listening) {
  const std::filesystem::path beside = library_folder() / kDashboardHttpLibrary;
  std::error_code ec;
  const std::string name = !beside.parent_path().empty() && std::filesystem::exists(beside, ec)
                               ? beside.string()
                               : std::string(kDashboardHttpLibrary);
  void* handle = dlopen(name.c_str(), RTLD_NOW | RTLD_LOCAL | RTLD_NODELETE);
  if (!handle) {
    const char* why = dlerror();
    throw InputError(fmt::format("dashboard: cannot load {} ({}); `varbo dashboard` needs it installed beside "
                                 "libvarbo_study.so",
                                 name, why ? why : "unknown reason"));
  }
  using Serve = void (*)(const DashboardHttp&);
  auto serve = reinterpret_cast<Serve>(dlsym(handle, kDashboardHttpSymbol));
  if (!serve)
    throw InputError(fmt::format("dashboard: {} has no entry point {}; reinstall varbo", name, kDashboardHttpSymbol));
  DashboardHttp http;
  http.get = [&api](const std::string& path, const ApiQuery& query) { return api.get(path, query); };
  http.host = host;
  http.port = port;
  http.on_listening = on_listening;
  serve(http);
}

}  // namespace varbo::cli

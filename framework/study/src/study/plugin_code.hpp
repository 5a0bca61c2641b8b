#pragma once
// Exceptions out of an algorithm and its components (surrogate, acquisition, optimizer, region, ... — possibly a
// third-party plugin's code) while a study is asked or told. varbo's own errors pass unchanged. Anything else —
// a std::runtime_error from a plugin's Surrogate::fit, or `throw 7`, which is not a std::exception at all and
// ended the process (std::terminate) — becomes a PluginCodeError (exit 2) that says what was being done and
// names the third-party plugins loaded, when there are any: before, it read "internal error: <their message>"
// (exit 3), blaming varbo and naming no plugin. With only varbo's own plugins it stays an internal error.
#include <cxxabi.h>
#include <fmt/format.h>

#include <exception>
#include <stdexcept>
#include <string>

#include "varbo/errors.hpp"
#include "varbo/loader.hpp"
#include "varbo/registry.hpp"
#include "varbo/text.hpp"

namespace varbo::detail {

/// "bo2 (/path/libvarbo_bo2.so), ..." for the loaded libraries that are not varbo's own; "" when none.
inline std::string third_party_plugins(const Registry& registry) {
  std::vector<std::string> seen;
  for (const ComponentInfo* c : registry.all()) {
    if (is_builtin(*c) || c->library.empty() || c->library.front() == '<') continue;  // '<': the Python module
    const std::string entry = fmt::format("{} ({})", c->plugin, c->library);
    if (std::find(seen.begin(), seen.end(), entry) == seen.end()) seen.push_back(entry);
  }
  return join(seen);
}

[[noreturn]] inline void rethrow_from_plugin_code(const Registry& registry, const std::string& doing,
                                                  const std::string& what, bool standard) {
  const std::string plugins = third_party_plugins(registry);
  if (plugins.empty()) {
    if (standard) throw;  // varbo's own code: an internal error, as it is
    throw std::runtime_error(fmt::format("{}: an exception that is not a std::exception", doing));
  }
  throw PluginCodeError(fmt::format("{}: {} — an exception from plugin code, not a varbo error; the third-party "
                                    "plugins loaded are: {}",
                                    doing, safe_text(what, 2000), plugins));
}

template <class F>
decltype(auto) in_plugin_code(const Registry& registry, const std::string& doing, F&& f) {
  try {
    return f();
  } catch (const Error&) {
    throw;
  } catch (const std::bad_alloc&) {
    throw;
  } catch (const abi::__forced_unwind&) {  // a thread ended by pthread_exit: its unwinding must go on
    throw;
  } catch (const std::exception& e) {
    rethrow_from_plugin_code(registry, doing, e.what(), true);
  } catch (...) {
    rethrow_from_plugin_code(registry, doing, "it threw something that is not a std::exception", false);
  }
}

/// Rethrows `thrown` when it is a T; else nothing.
template <class T>
void rethrow_if(const std::exception_ptr& thrown) {
  try {
    std::rethrow_exception(thrown);
  } catch (const T&) {
    throw;
  } catch (...) {
  }
}

/// Runs `f`; "" when it returns, else what it threw: a std::exception's message (bounded, printable) or a note that
/// it threw something else. Exceptions of the types `Pass...` propagate (a lost store connection, std::bad_alloc).
/// For the calls whose failure costs only an extra (a snapshot, a saved state, a recommendation), never a result.
template <class... Pass, class F>
std::string what_it_threw(F&& f) {
  try {
    f();
    return {};
  } catch (const abi::__forced_unwind&) {  // a thread ended by pthread_exit: its unwinding must go on
    throw;
  } catch (...) {
    const std::exception_ptr thrown = std::current_exception();
    (rethrow_if<Pass>(thrown), ...);
    try {
      std::rethrow_exception(thrown);
    } catch (const std::exception& e) {
      return safe_text(e.what(), 300);
    } catch (...) {
      return "it threw something that is not a std::exception";
    }
  }
}

}  // namespace varbo::detail

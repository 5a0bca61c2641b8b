// A study address picks its backend here, and only here: a postgresql:// URL is a study in a PostgreSQL
// database, anything else a SQLite file.
#include <fmt/format.h>

#include <cctype>
#include <filesystem>
#include <vector>

#include "store_url.hpp"
#include "varbo/errors.hpp"
#include "varbo/text.hpp"
#include "varbo/store.hpp"

namespace varbo {

namespace {

bool starts_with(const std::string& s, const char* prefix) { return s.rfind(prefix, 0) == 0; }

std::string percent_decode(const std::string& s) {
  std::string out;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '%' && i + 2 < s.size() && std::isxdigit(static_cast<unsigned char>(s[i + 1])) &&
        std::isxdigit(static_cast<unsigned char>(s[i + 2]))) {
      out += static_cast<char>(std::stoi(s.substr(i + 1, 2), nullptr, 16));
      i += 2;
    } else {
      out += s[i] == '+' ? ' ' : s[i];
    }
  }
  return out;
}

/// "user:secret@host" → "user:***@host" (the authority part of the URL).
std::string hide_password(const std::string& base) {
  const auto scheme_end = base.find("://");
  const auto auth_start = scheme_end == std::string::npos ? 0 : scheme_end + 3;
  const auto slash = base.find('/', auth_start);
  const auto at = base.rfind('@', slash == std::string::npos ? std::string::npos : slash);
  if (at == std::string::npos || at < auth_start) return base;
  const auto colon = base.find(':', auth_start);
  if (colon == std::string::npos || colon > at) return base;
  return base.substr(0, colon + 1) + "***" + base.substr(at);
}

}  // namespace

bool is_database_url(const std::string& address) {
  return starts_with(address, "postgresql://") || starts_with(address, "postgres://");
}

PostgresAddress parse_postgres_address(const std::string& url) {
  const std::string example = "postgresql://user@host/db?study=NAME, or postgresql:///db?host=/run/postgresql&study=NAME";
  if (!is_database_url(url))
    throw InputError(fmt::format("{}: not a PostgreSQL URL (expected {})", url, example));
  const auto q = url.find('?');
  const std::string base = url.substr(0, q);
  {
    // "user:pa@ss@host": libpq takes "ss@host" for the host name and quotes it in its error, password and all.
    const auto auth = base.find("://") + 3;
    const auto end = std::min(base.find('/', auth), base.size());
    const auto first_at = base.find('@', auth);
    if (first_at < end && base.find('@', first_at + 1) < end)
      throw InputError(fmt::format("{}: the user:password@host part holds more than one '@'; write an '@' of the "
                                   "user name or password as %40",
                                   hide_password(base)));
  }
  std::vector<std::string> kept, shown;
  PostgresAddress a;
  bool has_app = false, has_timeout = false, seen_study = false;
  if (q != std::string::npos) {
    const std::string query = url.substr(q + 1);
    std::size_t start = 0;
    while (start <= query.size()) {
      const auto amp = std::min(query.find('&', start), query.size());
      const std::string param = query.substr(start, amp - start);
      start = amp + 1;
      if (param.empty()) continue;
      const auto eq = param.find('=');
      const std::string key = param.substr(0, eq);
      if (key == "study") {
        const std::string name = eq == std::string::npos ? "" : percent_decode(param.substr(eq + 1));
        // `study=a&study=b` used b in silence: which study a worker writes to must never be a guess.
        if (seen_study && name != a.study)
          throw InputError(fmt::format("{}: the URL names two studies ('{}' and '{}'); give one study=NAME",
                                       hide_password(base), printable(a.study), printable(name)));
        seen_study = true;
        a.study = name;
        continue;
      }
      has_app = has_app || key == "application_name";
      has_timeout = has_timeout || key == "connect_timeout";
      kept.push_back(param);
      // sslpassword (the client key's passphrase) too: any key naming a password is shown hidden.
      shown.push_back(key.size() >= 8 && key.compare(key.size() - 8, 8, "password") == 0 ? key + "=***" : param);
    }
  }
  if (a.study.empty())
    throw InputError(fmt::format("{}: the URL names no study; add ?study=NAME (e.g. {})", hide_password(base), example));
  for (char c : a.study)
    if (!ascii_alnum(c) && c != '_' && c != '-' && c != '.')
      throw InputError(fmt::format("{}: study name '{}': use ASCII letters, digits, '_', '-' and '.' only",
                                   hide_password(base), a.study));
  if (a.study.size() > 200)
    throw InputError(fmt::format("{}: study name '{}…' is longer than 200 characters", hide_password(base),
                                 a.study.substr(0, 40)));
  std::vector<std::string> conn = kept;
  if (!has_app) conn.push_back("application_name=varbo");
  if (!has_timeout) conn.push_back("connect_timeout=10");  // an unreachable host fails in seconds, not minutes
  auto join = [](const std::vector<std::string>& v) {
    std::string s;
    for (const auto& p : v) s += (s.empty() ? "" : "&") + p;
    return s;
  };
  a.conninfo = base + "?" + join(conn);
  shown.push_back("study=" + a.study);
  a.display = hide_password(base) + "?" + join(shown);
  return a;
}

namespace {

/// SQLite gives ":memory:" and "file:" names meanings of their own (an in-memory database, a URI with options)
/// where SQLite reads them as such, and a file of that very name where it does not: `create(":memory:")` wrote a
/// file called ":memory:" (red team, session 27). A study must be a file another process can open, so both are
/// refused with the way to name such a file on purpose.
void check_sqlite_path(const std::string& address) {
  if (address.empty()) throw InputError("the study address is empty; give a file path (e.g. study.db) or a postgresql:// URL");
  if (address == ":memory:" || starts_with(address, "file:"))
    throw InputError(fmt::format("{}: SQLite reads this name as {}; a study is a file other processes can open: give "
                                 "a file path (./{} if you mean a file of this name) or a postgresql:// URL",
                                 printable(address), address == ":memory:" ? "an in-memory database" : "a URI",
                                 printable(address)));
}

}  // namespace

std::unique_ptr<StudyStore> create_store(const std::string& address,
                                         const std::vector<std::pair<std::string, std::string>>& meta) {
  if (is_database_url(address)) return create_postgres_store(address, meta);
  check_sqlite_path(address);
  return create_sqlite_store(address, meta);
}

std::unique_ptr<StudyStore> open_store(const std::string& address) {
  if (is_database_url(address)) return open_postgres_store(address);
  check_sqlite_path(address);
  return open_sqlite_store(address);
}

bool store_exists(const std::string& address) {
  if (!is_database_url(address)) return std::filesystem::exists(address);
  try {
    open_postgres_store(address);
    return true;
  } catch (const InputError& e) {
    // Only "no such study" means absent; a server that cannot be reached is an error, never "create a new one".
    if (std::string(e.what()).find("no study named") != std::string::npos) return false;
    throw;
  }
}

}  // namespace varbo

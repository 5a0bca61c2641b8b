#include "answer_parser.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <memory>
#include <vector>
#include <cmath>
#include <cstdlib>
#include <nlohmann/json.hpp>

#include "varbo/log.hpp"
#include "varbo/numbers.hpp"
#include "varbo/text.hpp"

namespace varbo::tasks {

namespace {

/// Costs beyond this are a failed trial: the models square costs (variances), which overflow past about 1e154, and
/// a script's "penalty" of 1e308 for a fall left every later model with an infinite variance — 5 of 15 trials
/// measured one θ again (audit, session 48). `varbo fit` refuses such values too.
constexpr double kLargestCost = 1e150;

std::string beyond_largest_cost(const std::string& text) {
  return fmt::format("the cost {} is beyond ±1e150, which the models cannot square; a penalty for a failure is "
                     "better reported as one ({{\"ok\": false}} or a non-zero exit: bo then learns where trials fail), "
                     "and a cost of that size rescaled (e.g. its log)",
                     abbreviate(text, 64));
}

std::string trim(const std::string& s) {
  const char* ws = " \t\r\n\f\v";
  const auto b = s.find_first_not_of(ws);
  if (b == std::string::npos) return "";
  return s.substr(b, s.find_last_not_of(ws) - b + 1);
}

// Strict: the whole text must be one number (strtod also accepts "nan"/"inf", rejected by the caller).
bool parse_number(const std::string& text, double& out) {
  const std::optional<double> v = varbo::parse_decimal(text);  // decimal only: "0x10" is not 16
  if (v) out = *v;
  return v.has_value();
}

/// nlohmann::json keeps the last of two equal keys: {"cost": 1, "cost": 2} was recorded as 2, silently (a
/// configuration with a key given twice is refused for the same reason). Notes the first repeated key, at any depth.
nlohmann::json::parser_callback_t duplicate_key_finder(std::string& duplicate) {
  auto seen = std::make_shared<std::vector<std::vector<std::string>>>();
  return [seen, &duplicate](int, nlohmann::json::parse_event_t event, nlohmann::json& parsed) {
    using E = nlohmann::json::parse_event_t;
    if (event == E::object_start) seen->emplace_back();
    if (event == E::object_end && !seen->empty()) seen->pop_back();
    if (event == E::key && !seen->empty() && parsed.is_string()) {
      const std::string key = parsed.get<std::string>();
      auto& keys = seen->back();
      if (duplicate.empty() && std::find(keys.begin(), keys.end(), key) != keys.end()) duplicate = key;
      keys.push_back(key);
    }
    return true;
  };
}

/// The first number token of `text` (a JSON answer) that overflows a double or is nonzero below its smallest (reads
/// as 0), or "".
std::string out_of_range_number(const std::string& text) {
  std::size_t i = 0;
  while (i < text.size()) {
    const char c = text[i];
    const bool starts = std::isdigit(static_cast<unsigned char>(c)) ||
                        (c == '-' && i + 1 < text.size() && std::isdigit(static_cast<unsigned char>(text[i + 1])));
    const bool inside_word = i > 0 && (std::isalnum(static_cast<unsigned char>(text[i - 1])) || text[i - 1] == '_' ||
                                       text[i - 1] == '.');
    if (!starts || inside_word) {
      ++i;
      continue;
    }
    std::size_t j = i + 1;
    while (j < text.size() && (std::isdigit(static_cast<unsigned char>(text[j])) || text[j] == '.' || text[j] == 'e' ||
                               text[j] == 'E' || ((text[j] == '+' || text[j] == '-') && (text[j - 1] == 'e' || text[j - 1] == 'E'))))
      ++j;
    const std::string token = text.substr(i, j - i);
    errno = 0;
    char* end = nullptr;
    const double v = strtod_c(token.c_str(), &end);
    if (end == token.c_str() + token.size() && errno == ERANGE && std::isinf(v)) return token;
    if (underflows_to_zero(token)) return token;
    i = j;
  }
  return "";
}

std::optional<Answer> from_json(const nlohmann::json& j, std::string& why) {
  if (!j.is_object()) {
    why = "the JSON answer is not an object";
    return std::nullopt;
  }
  // `"error": null` or `""` is no error: Python's json.dumps({"cost": c, "error": None}) writes exactly that, and
  // every trial of such a script failed with "the command reported an error: null" (red team, session 23).
  // `false` and 0 are no error either: a script's "no error" flag (`"error": False`) failed every trial with "the
  // command reported an error: false" (audit, session 44).
  const auto no_error = [](const nlohmann::json& e) {
    return e.is_null() || (e.is_string() && e.get<std::string>().empty()) || (e.is_boolean() && !e.get<bool>()) ||
           (e.is_number() && e.get<double>() == 0);
  };
  if (j.contains("error") && !no_error(j["error"])) {
    why = "the command reported an error: " +
          abbreviate(j["error"].is_string() ? j["error"].get<std::string>() : j["error"].dump(), 512);
    return std::nullopt;
  }
  // `"ok": false` is a failure, as varbo's own trials.csv column says: {"ok": false, "cost": 1e9, "reason": "fell"}
  // was recorded as a success with cost 1e9, which misled the model (red team, session 31).
  if (j.contains("ok")) {
    if (!j["ok"].is_boolean()) {
      why = "\"ok\" is not true or false: " + abbreviate(j["ok"].dump(), 512);
      return std::nullopt;
    }
    if (!j["ok"].get<bool>()) {
      const auto text = [&](const char* key) {
        return j.contains(key) && j[key].is_string() && !j[key].get<std::string>().empty()
                   ? std::optional<std::string>(j[key].get<std::string>())
                   : std::nullopt;
      };
      const auto reason = text("reason") ? text("reason") : text("message");
      why = "the command answered \"ok\": false" + (reason ? ": " + abbreviate(*reason, 512) : std::string());
      return std::nullopt;
    }
  }
  if (!j.contains("cost")) {
    why = "the JSON answer has no \"cost\"";
    return std::nullopt;
  }
  if (!j["cost"].is_number()) {
    why = "\"cost\" is not a number: " + abbreviate(j["cost"].dump(), 512);
    return std::nullopt;
  }
  Answer a;
  a.cost = j["cost"].get<double>();
  if (!std::isfinite(a.cost)) {
    why = "\"cost\" is not finite";
    return std::nullopt;
  }
  if (std::abs(a.cost) > kLargestCost) {
    why = beyond_largest_cost(j["cost"].dump());
    return std::nullopt;
  }
  if (j.contains("components")) {
    const auto& c = j["components"];
    if (!c.is_object()) {
      why = "\"components\" is not an object of numbers";
      return std::nullopt;
    }
    for (auto it = c.begin(); it != c.end(); ++it) {
      // A nameless component was stored and exported under an empty column header, where `varbo observe`
      // refuses it (audit, session 45).
      if (it.key().find_first_not_of(" \t") == std::string::npos) {
        why = "a component has an empty name";
        return std::nullopt;
      }
      if (!it.value().is_number() || !std::isfinite(it.value().get<double>())) {
        why = fmt::format("component \"{}\" is not a finite number: {}", abbreviate(it.key(), 512),
                        abbreviate(it.value().dump(), 512));
        return std::nullopt;
      }
      a.components.emplace_back(it.key(), it.value().get<double>());
    }
  }
  // Any other key is not read: said once per process, so a misspelled "components" or "Cost" is seen, while a
  // script that adds its own notes to the answer still runs.
  std::vector<std::string> unused;
  for (auto it = j.begin(); it != j.end(); ++it)
    if (it.key() != "cost" && it.key() != "components" && it.key() != "error" && it.key() != "ok" &&
        it.key() != "reason" && it.key() != "message")
      unused.push_back("\"" + printable(abbreviate(it.key(), 64)) + "\"");
  if (!unused.empty())
    log_warn_once(fmt::format("the external command's JSON answer has key(s) {} that varbo does not read (an answer is "
                              "\"cost\" and optionally \"components\"; \"error\" or \"ok\": false report a failure)",
                              fmt::join(unused, ", ")));
  return a;
}

}  // namespace

std::string last_nonempty_line(const std::string& text) {
  std::size_t end = text.size();
  while (end > 0) {
    const std::size_t start = text.rfind('\n', end - 1);
    const std::size_t b = start == std::string::npos ? 0 : start + 1;
    std::string line = trim(text.substr(b, end - b));
    if (!line.empty()) return line;
    if (start == std::string::npos) break;
    end = start;
  }
  return "";
}

std::optional<Answer> parse_answer(const std::string& stdout_text, std::string& why) {
  std::string last = last_nonempty_line(stdout_text);
  // A UTF-8 byte-order mark (a Windows editor's, a PowerShell script's) before the number: invisible in the
  // message "the last line '1.5' is not a number" (red team, session 28). It is not part of the answer.
  if (last.rfind("\xEF\xBB\xBF", 0) == 0) last.erase(0, 3);
  if (last.empty()) {
    why = "no output on stdout";
    return std::nullopt;
  }
  double v = 0;
  if (parse_number(last, v)) {
    if (!std::isfinite(v)) {
      why = fmt::format("the cost '{}' is not a finite number", abbreviate(last, 512));
      return std::nullopt;
    }
    if (std::abs(v) > kLargestCost) {
      why = beyond_largest_cost(last);
      return std::nullopt;
    }
    return Answer{v, {}};
  }
  // A JSON object: on the last line, or spread over the last lines; try the suffixes that start at a
  // line beginning with '{', nearest the end first (a few, so log-heavy output stays cheap).
  if (last.back() == '}') {
    std::size_t pos = stdout_text.size();
    for (int tries = 0; tries < 64 && pos > 0; ++tries) {
      const std::size_t brace = stdout_text.rfind('{', pos - 1);
      if (brace == std::string::npos) break;
      pos = brace;
      const std::size_t nl = brace == 0 ? std::string::npos : stdout_text.rfind('\n', brace - 1);
      const std::size_t line_start = nl == std::string::npos ? 0 : nl + 1;
      const std::string before = trim(stdout_text.substr(line_start, brace - line_start));
      if (!before.empty()) continue;  // not at the start of a line: an inner object
      std::string duplicate;
      const auto j = nlohmann::json::parse(stdout_text.substr(brace), duplicate_key_finder(duplicate),
                                           /*allow_exceptions=*/false);
      if (j.is_discarded()) continue;
      // nlohmann reads 1e-400 as 0 without a word: such a number is said, as on a plain last line.
      if (const std::string tiny = out_of_range_number(stdout_text.substr(brace)); !tiny.empty()) {
        why = fmt::format("the JSON answer holds the number '{}', below the smallest number a double holds (about "
                          "4.9e-324): it would read as 0", abbreviate(tiny, 64));
        return std::nullopt;
      }
      if (!duplicate.empty()) {
        why = fmt::format("the JSON answer gives the key \"{}\" twice; which one is meant is unknown",
                          abbreviate(duplicate, 512));
        return std::nullopt;
      }
      return from_json(j, why);
    }
    // A number out of a double's range inside the object makes the JSON parser refuse it all: said as such
    // ({"components": {"a": 1e999}} read "neither a number nor a valid JSON object"; audit, session 44).
    const std::size_t open = stdout_text.find('{');
    if (const std::string bad = out_of_range_number(stdout_text.substr(open == std::string::npos ? 0 : open));
        !bad.empty()) {
      why = fmt::format("the JSON answer holds the number '{}', beyond the range of a double (about ±1.8e308)",
                        abbreviate(bad, 64));
      return std::nullopt;
    }
    why = fmt::format("the answer '{}' is neither a number nor a valid JSON object", abbreviate(last, 512));
    return std::nullopt;
  }
  {
    // A decimal number that overflows (1e400) reads as nothing above: say so rather than "not a number".
    errno = 0;
    char* end = nullptr;
    const double big = strtod_c(last.c_str(), &end);
    if (end != nullptr && *end == '\0' && errno == ERANGE && std::isinf(big) &&
        last.find_first_of("xX") == std::string::npos) {
      why = fmt::format("the cost '{}' is beyond the range of a double (about ±1.8e308)", abbreviate(last, 512));
      return std::nullopt;
    }
  }
  if (underflows_to_zero(last)) {
    why = fmt::format("the cost '{}' is below the smallest number a double holds (about 4.9e-324) and would read as 0; "
                      "print 0 if that is meant", abbreviate(last, 512));
    return std::nullopt;
  }
  std::string with_point = last;
  double ignored = 0;
  if (std::count(last.begin(), last.end(), ',') == 1 && (std::replace(with_point.begin(), with_point.end(), ',', '.'),
                                                          parse_number(with_point, ignored))) {
    // A program printing in a decimal-comma locale (printf under LC_NUMERIC=de_DE): never read as 1 or 15.
    why = fmt::format("the last line '{}' is not a number: write the decimal point as '.' ({}); a program printing "
                      "in a decimal-comma locale can run with LC_NUMERIC=C",
                      abbreviate(last, 512), with_point);
    return std::nullopt;
  }
  why = fmt::format("the last line '{}' is not a number", abbreviate(last, 512));
  return std::nullopt;
}

}  // namespace varbo::tasks

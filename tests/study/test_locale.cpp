// A host process in a decimal-comma locale: Python's locale.setlocale, a Qt, GTK or ROS GUI (setlocale(LC_ALL, "")
// with LANG=de_DE.UTF-8). strtod then stops at the '.', and varbo refused 15 plugins' defaults ("0.01 is not a real
// number"), every configuration real ("-5.5") and its own saved states (red team, session 28). Numbers are read as
// in the "C" locale whatever the process's.
#include <clocale>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <locale>
#include <sstream>

#include "study_helpers.hpp"
#include "varbo/config.hpp"
#include "varbo/errors.hpp"
#include "varbo/numbers.hpp"
#include "varbo/search_space_config.hpp"
#include "varbo/store.hpp"
#include "varbo/study.hpp"
#include "varbo/study_api.hpp"
#include "varbo_test.hpp"

using namespace varbo;
using varbo::test::temp_folder;

namespace {

/// de_DE.UTF-8 compiled from the `locales` package's sources into `dir` (no system-wide locale needed), made the
/// process's LC_NUMERIC; the "C" locale again when it goes out of scope.
struct DecimalCommaLocale {
  explicit DecimalCommaLocale(const std::string& dir) {
    const std::string cmd = "localedef -c -i de_DE -f UTF-8 " + dir + "/de_DE.UTF-8 >/dev/null 2>&1";
    [[maybe_unused]] const int rc = std::system(cmd.c_str());  // 1 = built with warnings
    setenv("LOCPATH", dir.c_str(), 1);
    active = std::setlocale(LC_NUMERIC, "de_DE.UTF-8") != nullptr && std::localeconv()->decimal_point[0] == ',';
  }
  ~DecimalCommaLocale() {
    std::setlocale(LC_NUMERIC, "C");
    unsetenv("LOCPATH");
  }
  bool active = false;
};

/// A locale compiled from the `locales` package's sources into `dir` (as DecimalCommaLocale), e.g. en_US.UTF-8 or
/// de_DE.ISO-8859-1; nullopt when localedef could not build it.
std::optional<std::locale> compiled_locale(const std::string& dir, const std::string& source, const std::string& charmap,
                                           const std::string& name) {
  const std::string cmd = "localedef -c -i " + source + " -f " + charmap + " " + dir + "/" + name + " >/dev/null 2>&1";
  [[maybe_unused]] const int rc = std::system(cmd.c_str());
  setenv("LOCPATH", dir.c_str(), 1);
  try {
    return std::locale(name.c_str());
  } catch (const std::runtime_error&) {
    return std::nullopt;
  }
}

/// The host's global C++ locale while alive (std::locale::global also sets the C locale of a named one); "C" again
/// afterwards.
struct GlobalLocale {
  explicit GlobalLocale(const std::locale& l) { std::locale::global(l); }
  ~GlobalLocale() {
    std::locale::global(std::locale::classic());
    unsetenv("LOCPATH");
  }
};

}  // namespace

TEST_CASE("a host's global C++ locale (decimal comma, thousands grouping) changes no number varbo writes") {
  // std::locale::global(std::locale("")) under LANG=de_DE.UTF-8 or en_US.UTF-8: yaml-cpp's stream formatted the
  // stored configuration as `xi: 0,01`, `candidates: 2,000`, `budget: 1,003`, a study no other process could open,
  // and trials.csv's index 1000 as "1,000", a 13th field (red team, session 31).
  const std::string dir = temp_folder("locale_global");
  const std::string yaml =
      "task: {type: external, command: 'true', names: [a, b], lower: [-5.5, 0.25], upper: [2.5, 1.75]}\n"
      "algorithm: {type: bo, initial_points: 3, acquisition: {type: ei, xi: 0.01}}\n"
      "budget: 1003\nseed: 12345\nheartbeat_timeout: 2.5\ninitial_point: [0.5, 1.25]\n";
  // The same study created in the "C" locale: what every other process writes.
  const std::string reference = dir + "/c.db";
  std::string reference_config, reference_identity;
  {
    Study s = Study::create_from_yaml(reference, yaml, "locale.yaml");
    reference_config = s.store().meta(store_key::kConfig).value_or("");
    reference_identity = s.store().meta(store_key::kIdentity).value_or("");
  }
  REQUIRE(reference_config.find("1003") != std::string::npos);
  for (const auto& [source, name] : {std::pair<std::string, std::string>{"de_DE", "de_DE.UTF-8"}, {"en_US", "en_US.UTF-8"}}) {
    CAPTURE(name);
    const auto loc = compiled_locale(dir, source, "UTF-8", name);
    REQUIRE_MESSAGE(loc, "localedef could not build " << name << " (Debian package `locales`, scripts/setup.sh)");
    const std::string store = dir + "/" + source + ".db";
    {
      GlobalLocale global(*loc);
      std::ostringstream probe;
      probe << 1003 << ' ' << 0.5;
      CHECK(probe.str() != "1003 0.5");  // the trap itself: a default stream follows the host's locale
      Study s = Study::create_from_yaml(store, yaml, "locale.yaml");
      CHECK(s.store().meta(store_key::kConfig).value_or("") == reference_config);
      CHECK(s.store().meta(store_key::kIdentity).value_or("") == reference_identity);
      for (int i = 0; i < 4; ++i) {
        const auto t = s.ask().at(0);
        s.tell(t.id, (t.theta[0] - 0.5) * (t.theta[0] - 0.5) + t.theta[1]);
      }
    }
    // Opened by a process in the "C" locale: the same study, every saved state read.
    Study s = Study::open(store);
    CHECK(s.config().budget == 1003);
    CHECK(s.domain().box.lower[0] == -5.5);
    CHECK(s.verify().divergence.empty());
  }

  // A run's files: trials.csv's index and model.yaml's iteration are written with <<.
  const auto us = compiled_locale(dir, "en_US", "UTF-8", "en_US.UTF-8");
  REQUIRE(us);
  const std::string cfg = dir + "/random.yaml";
  std::ofstream(cfg) << "task: branin\nbudget: 1002\nseed: 3\nthreads: 1\nalgorithm: {type: random}\noutput: " << dir
                     << "/random_run\n";
  {
    GlobalLocale global(*us);
    RunOverrides ov;
    ov.progress = false;
    run_study_file(cfg, ov);
  }
  const std::string csv = test::slurp(dir + "/random_run/trials.csv");
  CHECK(csv.find("\n1000,") != std::string::npos);
  CHECK(csv.find("1,000") == std::string::npos);
  CHECK(test::slurp(dir + "/random_run/config.resolved.yaml").find("budget: 1002") != std::string::npos);
}

TEST_CASE("a parameter name is ASCII whatever the process's LC_CTYPE") {
  // In a Latin-1 locale (setlocale(LC_ALL, "de_DE") in older host code) std::isalnum took both bytes of a UTF-8
  // 'µ' for letters: Python created a study with `delay_µs` that `varbo suggest` then refused (red team, session 31).
  const std::string dir = temp_folder("locale_ctype");
  const auto latin1 = compiled_locale(dir, "de_DE", "ISO-8859-1", "de_DE.ISO-8859-1");
  REQUIRE_MESSAGE(latin1, "localedef could not build de_DE.ISO-8859-1");
  REQUIRE(std::setlocale(LC_CTYPE, "de_DE.ISO-8859-1") != nullptr);
  CHECK(std::isalnum(0xB5));  // the trap itself: in Latin-1 0xB5 is a letter (µ)
  const ConfigNode params = ConfigNode::parse(
      "- {name: delay_\xC2\xB5s, type: real, low: 0, high: 1}\n", "latin1.yaml");
  CHECK_THROWS_WITH_AS(parse_search_space(params), doctest::Contains("a parameter name is ASCII letters"), ConfigError);
  std::setlocale(LC_CTYPE, "C");
  unsetenv("LOCPATH");
}

TEST_CASE("numbers, configurations, plugins and saved states read the same in a decimal-comma locale") {
  const std::string dir = temp_folder("locale");
  DecimalCommaLocale de(dir);
  REQUIRE_MESSAGE(de.active, "localedef could not build de_DE.UTF-8 (Debian package `locales`, scripts/setup.sh)");
  CHECK(std::strtod("0.5", nullptr) == 0.0);  // the trap itself: the process's strtod stops at '.'

  CHECK(parse_decimal("0.01") == 0.01);
  CHECK(parse_decimal("-1.5e-3") == -1.5e-3);
  CHECK_FALSE(parse_decimal("0,5"));  // never the host's notation: one rule for every file and answer
  char* end = nullptr;
  const char* text = "2.25 rest";
  CHECK(strtod_c(text, &end) == 2.25);
  CHECK(end == text + 4);

  // A bo study with real-valued keys (task bounds, kernel and acquisition defaults of the plugins, loaded now),
  // driven through a fresh Study for each step: every process after the first restores the saved state.
  const std::string yaml =
      "task: {type: external, command: 'true', names: [a, b], lower: [-5.5, 0.25], upper: [2.5, 1.75]}\n"
      "algorithm: {type: bo, initial_points: 3, acquisition: {type: ei, xi: 0.01}}\n"
      "budget: 6\nseed: 4\n";
  const std::string store = dir + "/s.db";
  {
    Study s = Study::create_from_yaml(store, yaml, "locale.yaml");
    CHECK(s.domain().box.lower[0] == -5.5);
    CHECK(s.domain().box.upper[1] == 1.75);
  }
  for (int i = 0; i < 6; ++i) {
    Study s = Study::open(store);
    const auto t = s.ask().at(0);
    CHECK(s.domain().box.contains(t.theta, 0.0));
    s.tell(t.id, (t.theta[0] - 0.5) * (t.theta[0] - 0.5) + t.theta[1]);
  }
  Study s = Study::open(store);
  const VerifyReport r = s.verify();
  CHECK(r.divergence.empty());
  CHECK(r.replayed == 6);
}

// A host process in a decimal-comma locale: Python's locale.setlocale, a Qt, GTK or ROS GUI (setlocale(LC_ALL, "")
// with LANG=de_DE.UTF-8). strtod then stops at the '.', and varbo refused 15 plugins' defaults ("0.01 is not a real
// number"), every configuration real ("-5.5") and its own saved states (red team, session 28). Numbers are read as
// in the "C" locale whatever the process's.
#include <clocale>
#include <cstdlib>
#include <filesystem>

#include "study_helpers.hpp"
#include "varbo/numbers.hpp"
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

}  // namespace

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

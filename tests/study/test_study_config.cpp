// Study files: every mistake is an error with file:line:col, the key path and what was expected.
#include "study_helpers.hpp"
#include "varbo/errors.hpp"
#include "varbo_test.hpp"

using namespace varbo;

namespace {
std::string study_error(const std::string& yaml) {
  try {
    parse_study(ConfigNode::parse(yaml, "s.yaml"), test::registry());
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "(no error)";
}
bool has(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }
}  // namespace

TEST_CASE("a minimal study resolves every default") {
  StudyConfig s = parse_study(ConfigNode::parse("task: branin\n", "s.yaml"), test::registry());
  CHECK(s.budget == 30);
  CHECK(s.algorithm.info->name == "bo");
  YAML::Node r = s.resolved();
  CHECK(r["algorithm"]["surrogate"]["type"].as<std::string>() == "gp");
  CHECK(r["algorithm"]["acquisition"]["type"].as<std::string>() == "ei");
  CHECK(r["algorithm"]["surrogate"]["fit_optimizer"]["type"].as<std::string>() == "ceres_lbfgs");
}

TEST_CASE("a missing task is an error") {
  CHECK(has(study_error("budget: 3\n"), "key 'task': missing required key for the study"));
}

TEST_CASE("an unknown component name lists the known ones") {
  const std::string m = study_error("task: {type: brannin}\n");
  CHECK(has(m, "s.yaml:1:14: key 'task.type': unknown task 'brannin'. Known: "));
  CHECK(has(m, "did you mean 'branin'?"));
}

TEST_CASE("a nested unknown key names the full key path") {
  const std::string m = study_error("task: branin\nalgorithm:\n  type: bo\n  surrogate: {type: gp, kernal: se_ard}\n");
  CHECK(has(m, "s.yaml:4:25: key 'algorithm.surrogate.kernal': unknown key for surrogate 'gp'"));
  CHECK(has(m, "did you mean 'kernel'?"));
}

TEST_CASE("out-of-range and mistyped top-level values") {
  CHECK(study_error("task: branin\nbudget: 0\n") ==
        "s.yaml:2:9: key 'budget': expected an integer in [1, inf), got '0'");
  CHECK(study_error("task: branin\nseed: many\n") ==
        "s.yaml:2:7: key 'seed': expected an integer in [0, inf), got 'many'");
  CHECK(study_error("task: branin\nseed: 18446744073709551616\n").find(
            "key 'seed': expected an integer in [0, inf), got '18446744073709551616': beyond the largest integer a "
            "setting holds (9223372036854775807)") != std::string::npos);
  CHECK(has(study_error("task: branin\nbudgett: 3\n"), "did you mean 'budget'?"));
}

TEST_CASE("a component given as a list is refused") {
  CHECK(has(study_error("task: [branin]\n"), "key 'task': expected a task name or a map with 'type:'"));
  // "an" before a vowel: the message is read by people.
  CHECK(has(study_error("task: branin\nalgorithm: [bo]\n"),
            "key 'algorithm': expected an algorithm name or a map with 'type:'"));
  CHECK(has(study_error("task: branin\nalgorithm: {type: [bo]}\n"),
            "key 'algorithm.type': expected an algorithm name"));
}

TEST_CASE("phases are validated with their own key paths") {
  StudyConfig s = parse_study(ConfigNode::parse("task: branin\nalgorithm:\n  type: bo\n  phases:\n"
                                                "    - {evaluations: 3, random: true}\n"
                                                "    - {evaluations: 2, acquisition: {type: ei, xii: 1}}\n",
                                                "s.yaml"),
                              test::registry());
  // Phases are checked when the algorithm is built (before any trial).
  BuildContext ctx;
  ctx.dim = 2;
  ctx.budget = 10;
  try {
    test::registry().create<Algorithm>(s.algorithm, ctx);
    FAIL("expected ConfigError");
  } catch (const ConfigError& e) {
    CHECK(has(e.what(), "s.yaml:6:48: key 'algorithm.phases[1].acquisition.xii': unknown key for acquisition 'ei'"));
  }
}

TEST_CASE("an initial point of the wrong size is refused before any trial") {
  const std::string out = test::temp_folder("bad_initial_point");
  try {
    test::run_yaml("task: branin\ninitial_point: [1, 2, 3]\noutput: " + out + "\n", test::registry());
    FAIL("expected ConfigError");
  } catch (const ConfigError& e) {
    CHECK(has(e.what(), "key 'initial_point': expected 2 values (the task's dimension), got 3"));
  }
}

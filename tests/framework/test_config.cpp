// ConfigNode: positions and key paths in every message.
#include "varbo/config.hpp"
#include "varbo/errors.hpp"
#include "varbo_test.hpp"

using namespace varbo;

TEST_CASE("a YAML syntax error names file, line and column") {
  try {
    ConfigNode::parse("a: 1\nb: [1, 2\n", "bad.yaml");
    FAIL("expected a ConfigError");
  } catch (const ConfigError& e) {
    const std::string m = e.what();
    CHECK(m.rfind("bad.yaml:", 0) == 0);
    CHECK(m.find("YAML syntax error") != std::string::npos);
  }
}

TEST_CASE("a child node keeps its position and key path") {
  ConfigNode root = ConfigNode::parse("task:\n  type: branin\n  noise_std: abc\n", "t.yaml");
  ConfigNode n = root.child("task").child("noise_std");
  CHECK(n.path() == "task.noise_std");
  CHECK(n.where() == "t.yaml:3:14");
  try {
    n.fail("expected a real number");
    FAIL("expected a ConfigError");
  } catch (const ConfigError& e) {
    CHECK(std::string(e.what()) == "t.yaml:3:14: key 'task.noise_std': expected a real number");
  }
}

TEST_CASE("an absent child reports its parent's position") {
  ConfigNode root = ConfigNode::parse("task:\n  type: branin\n", "t.yaml");
  ConfigNode n = root.child("task").child("dim");
  CHECK_FALSE(n.defined());
  CHECK(n.where() == "t.yaml:2:3");
}

TEST_CASE("loading a missing file is a clear error") {
  CHECK_THROWS_WITH_AS(ConfigNode::load_file("/nonexistent/x.yaml"),
                       "/nonexistent/x.yaml: cannot open configuration file", ConfigError);
}

TEST_CASE("closest_match suggests near names only") {
  CHECK(closest_match("xii", {"xi", "kappa"}) == "xi");
  CHECK(closest_match("zzzzzz", {"xi", "kappa"}).empty());
  // Session 23: a word replaced whole is no near miss ("1" suggested "pd" for a category's index).
  CHECK(closest_match("1", {"pd", "lqr", "mpc"}).empty());
  CHECK(closest_match("ab", {"xy"}).empty());
  CHECK(closest_match("pf", {"pd", "lqr"}) == "pd");
  CHECK(closest_match("lqrr", {"pd", "lqr"}) == "lqr");
}

namespace {
std::string parse_error(const std::string& text) {
  try {
    ConfigNode::parse(text, "c.yaml");
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST_CASE("what yaml-cpp accepts silently is an error: duplicate keys, a second document, unknown tags") {
  // yaml-cpp keeps the first of two equal keys: `budget: 4` then `budget: 6` would run 4.
  CHECK(parse_error("budget: 4\nbudget: 6\n") ==
        "c.yaml:2:1: duplicate key 'budget' (first given at line 1); each key may appear once in a map");
  CHECK(parse_error("algorithm:\n  type: bo\n  surrogate: {type: gp, restarts: 2, restarts: 3}\n")
            .rfind("c.yaml:3:38: duplicate key 'restarts'", 0) == 0);
  CHECK(parse_error("a: 1\n---\nb: 2\n").rfind("c.yaml:2:1: a second YAML document", 0) == 0);  // at its ---
  CHECK(parse_error("a: !custom 1\n").rfind("c.yaml:1:4: unknown YAML tag '!custom'", 0) == 0);
  CHECK(parse_error("a: !!binary aGk=\n").find("unknown YAML tag") != std::string::npos);
  CHECK(parse_error("? [1, 2]\n: 3\n").find("a key must be a plain name") != std::string::npos);
  // Still fine: one document with its start marker, core-schema tags, quoted values, the same key in two maps.
  CHECK(parse_error("---\na: !!str 1\nb: \"x\"\nc: {k: 1}\nd: {k: 2}\n").empty());
  CHECK(parse_error("").empty());
}

TEST_CASE("YAML merge keys (<<) give shared defaults: the map's own keys win, then the merged maps in order") {
  // yaml-cpp 0.7 reads '<<' as an ordinary key; ConfigNode resolves it (https://yaml.org/type/merge.html).
  const ConfigNode root = ConfigNode::parse(
      "gp: &gp {type: gp, restarts: 2, kernel: se_ard}\n"
      "fast: &fast {restarts: 1, full_fit_growth: 2}\n"
      "a: {<<: *gp, restarts: 8}\n"
      "b:\n  <<: [*fast, *gp]\n"
      "c: {\"<<\": 5}\n",
      "c.yaml");
  const ConfigNode a = root.child("a");
  CHECK(a.keys() == std::vector<std::string>{"restarts", "type", "kernel"});
  CHECK(a.child("restarts").scalar() == "8");
  CHECK(a.child("type").scalar() == "gp");
  CHECK(a.child("kernel").where() == "c.yaml:1:41");  // a merged value keeps the anchor's position
  const ConfigNode b = root.child("b");
  CHECK(b.child("restarts").scalar() == "1");  // the earlier map in the list wins
  CHECK(b.child("full_fit_growth").scalar() == "2");
  CHECK(b.child("type").scalar() == "gp");
  CHECK_FALSE(b.has("<<"));
  CHECK(root.child("c").child("<<").scalar() == "5");  // quoted: an ordinary key
  // The anchored maps themselves are unchanged.
  CHECK(root.child("gp").child("restarts").scalar() == "2");
  CHECK(root.child("fast").keys() == std::vector<std::string>{"restarts", "full_fit_growth"});
}

TEST_CASE("bad merge keys and alias bombs are errors with a position") {
  CHECK(parse_error("a: {type: x, <<: 5}\n") ==
        "c.yaml:1:18: the merge key '<<' takes a map or a list of maps (e.g. <<: *defaults), got '5'");
  CHECK(parse_error("m: &m {k: 1}\na: {<<: [*m, 3]}\n").find("the merge key '<<' takes a map or a list of maps") !=
        std::string::npos);
  CHECK(parse_error("m: &m {k: 1}\na:\n  <<: *m\n  <<: *m\n").rfind("c.yaml:4:3: duplicate merge key '<<' (first given "
                                                                   "at line 3)",
                                                                   0) == 0);
  // "Billion laughs": 9 levels of 10 aliases each expand to 10^10 values; refused at once instead of hanging.
  std::string bomb = "l0: &l0 [x, x, x, x, x, x, x, x, x, x]\n";
  for (int i = 1; i < 10; ++i) {
    // Appended piecewise: `"l" + std::to_string(i)` (const char* + std::string&&) trips GCC 12's -Wrestrict.
    const std::string level = std::to_string(i), below = std::to_string(i - 1);
    bomb += "l";
    bomb += level;
    bomb += ": &l";
    bomb += level;
    bomb += " [";
    for (int k = 0; k < 10; ++k) {
      bomb += k ? ", *l" : "*l";
      bomb += below;
    }
    bomb += "]\n";
  }
  CHECK(parse_error(bomb).find("expands to more than 1000000 values through its aliases") != std::string::npos);
}

TEST_CASE("keys and values must be UTF-8; a suffix after '_' is suggested (audit11a)") {
  // A Latin-1 'é' (0xE9) reached the run folder as a stray byte.
  CHECK(parse_error("task: branin\ndescription: caf\xE9\n") ==
        "c.yaml:2:14: byte 0xE9 (at offset 3 of this value) is not UTF-8; save the file as UTF-8");
  CHECK(parse_error("bud\xFFget: 2\n").rfind("c.yaml:1:1: byte 0xFF", 0) == 0);
  CHECK(parse_error("description: \"caf\xC3\xA9 \xE2\x82\xAC\"\n").empty());  // é and € in UTF-8 are fine
  CHECK(closest_match("lbfgs", {"ceres_lbfgs", "nlopt"}) == "ceres_lbfgs");
  CHECK(closest_match("ard", {"se_ard"}).empty());  // too short a word for the suffix rule
}

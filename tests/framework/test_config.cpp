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
  CHECK(parse_error("a: 1\n---\nb: 2\n").rfind("c.yaml:3:1: a second YAML document", 0) == 0);
  CHECK(parse_error("a: !custom 1\n").rfind("c.yaml:1:4: unknown YAML tag '!custom'", 0) == 0);
  CHECK(parse_error("a: !!binary aGk=\n").find("unknown YAML tag") != std::string::npos);
  CHECK(parse_error("? [1, 2]\n: 3\n").find("a key must be a plain name") != std::string::npos);
  // Still fine: one document with its start marker, core-schema tags, quoted values, the same key in two maps.
  CHECK(parse_error("---\na: !!str 1\nb: \"x\"\nc: {k: 1}\nd: {k: 2}\n").empty());
  CHECK(parse_error("").empty());
}

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

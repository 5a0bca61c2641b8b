// Every registered component's declared defaults (what `varbo plugins --describe` shows, and what a run uses
// when the key is absent) are valid values of the option itself: a settings-struct default outside the declared
// bounds or choices, or a default component that does not exist, fails here rather than in a user's run.
#include <string>

#include "varbo/errors.hpp"
#include "varbo_test.hpp"

using namespace varbo;

TEST_CASE("every component's defaults validate against its own option declarations") {
  const Registry& r = test::registry();
  const auto all = r.all();
  REQUIRE(all.size() > 20);  // the build tree's plugins are loaded
  long checked = 0;
  for (const ComponentInfo* c : all) {
    for (const OptionSpec& s : c->options) {
      if (s.default_yaml.empty() || s.type == OptionType::Node) continue;
      CAPTURE(c->full_name());
      CAPTURE(s.name);
      CAPTURE(s.default_yaml);
      // Only this option, absent from the config: the default is validated exactly as a user's value would be.
      const std::vector<OptionSpec> one{s};
      Options o;
      CHECK_NOTHROW(o = validate_options(ConfigNode::parse("{}", "<test>"), one, c->full_name(), &r));
      CHECK(o.is_set(s.name));
      CHECK_FALSE(o.given(s.name));
      ++checked;
    }
  }
  CHECK(checked > 100);
}

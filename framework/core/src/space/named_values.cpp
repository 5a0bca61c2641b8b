// θ of name=value texts: the parsing behind `varbo observe new --param` and Python's Study.tell_point.
#include "varbo/named_values.hpp"

#include <fmt/format.h>

#include "varbo/config.hpp"
#include "varbo/errors.hpp"

namespace varbo {

Vec theta_of_named(const SearchSpace& space, const std::vector<std::pair<std::string, std::string>>& values,
                   const std::string& what) {
  const std::vector<std::string> all = space.names();
  Vec theta = space.user_box().lower;  // fixed parameters keep their value
  std::vector<bool> given(space.size(), false);
  for (const auto& [name, text] : values) {
    const auto i = space.index_of(name);
    if (!i) {
      const std::string near = closest_match(name, all);
      throw InputError(fmt::format("{}: the study has no parameter '{}' (it has {}){}; nothing written", what, name,
                                   join(all), near.empty() ? "" : "; did you mean '" + near + "'?"));
    }
    if (given[*i]) throw InputError(fmt::format("{}: '{}' is given twice; nothing written", what, name));
    given[*i] = true;
    try {
      theta[static_cast<Index>(*i)] = space.parse_value(*i, text);
    } catch (const InputError& e) {
      throw InputError(fmt::format("{}: {}; nothing written", what, e.what()));
    }
  }
  std::vector<std::string> missing;
  for (std::size_t i = 0; i < space.size(); ++i)
    if (!given[i] && space.parameters()[i].type != ParameterType::Fixed) missing.push_back(space.parameters()[i].name);
  if (!missing.empty())
    throw InputError(fmt::format("{}: missing {} (every parameter of the study needs a value); nothing written", what,
                                 join(missing)));
  return theta;
}

}  // namespace varbo

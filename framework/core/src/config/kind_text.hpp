#pragma once
// Component kinds in messages (internal to varbo::core: not part of the SDK headers).
#include <string>

#include "varbo/options.hpp"

namespace varbo {

/// "an algorithm", "a surrogate": the kind's name with its indefinite article.
std::string kind_with_article(Kind kind);

}  // namespace varbo

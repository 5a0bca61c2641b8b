#pragma once
// The fixtures the bo tests share: a bowl with its minimum at 0.3 in every coordinate, and a 2-D bo built
// from its YAML with a fixed seed.
#include <memory>
#include <string>

#include "varbo/algorithm.hpp"
#include "varbo/registry.hpp"
#include "varbo_test.hpp"

namespace varbo::test {

inline double bowl(const Vec& x) { return (x.array() - 0.3).square().sum(); }

inline std::unique_ptr<Algorithm> make_bo(const std::string& algorithm, Index budget) {
  BuildContext ctx;
  ctx.dim = 2;
  ctx.budget = budget;
  ctx.seed = 5;
  return registry().create<Algorithm>(algorithm, ctx);
}

}  // namespace varbo::test

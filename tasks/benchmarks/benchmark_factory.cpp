#include "benchmark_factory.hpp"

#include <fmt/format.h>

#include "benchmark_task.hpp"
#include "failure_region.hpp"

namespace varbo::tasks {

std::vector<OptionSpec> benchmark_options(const BenchmarkSpec& spec) {
  std::vector<OptionSpec> o;
  if (spec.fixed_dim == 0)
    o.push_back(opt::integer("dim", static_cast<long>(spec.default_dim), "number of dimensions")
                    .at_least(static_cast<double>(spec.min_dim)).at_most(1000));
  o.push_back(opt::reals("bounds", "",
                         "[lo, hi] applied to every dimension, replacing the standard domain (optional)"));
  o.push_back(opt::real("noise_std", 0.0, "std of additive Gaussian noise on the cost").at_least(0));
  o.push_back(opt::node("failure_region", "",
                        "trials inside fail (no cost), for testing failure handling: {shape: ball, center: [...], "
                        "radius: r} or {shape: box, lower: [...], upper: [...]}, in fractions of the box"));
  return o;
}

std::unique_ptr<Task> make_benchmark_task(const BenchmarkSpec& spec, const Options& options) {
  const Index dim = spec.fixed_dim > 0 ? spec.fixed_dim : static_cast<Index>(options.integer("dim"));
  Box box = spec.domain(dim);
  if (options.is_set("bounds")) {
    const auto b = options.reals("bounds");
    if (b.size() != 2 || !(b[0] < b[1]))
      options.node("bounds").fail(fmt::format("expected [lo, hi] with lo < hi, got {} value(s){}", b.size(),
                                              b.size() == 2 ? fmt::format(" [{}, {}]", b[0], b[1]) : ""));
    box = Box{Vec::Constant(dim, b[0]), Vec::Constant(dim, b[1])};
  }
  auto task = std::make_unique<BenchmarkTask>(spec, dim, std::move(box), options.real("noise_std"));
  task->set_failure_region(parse_failure_region(options, dim));
  return task;
}

}  // namespace varbo::tasks

// Template for a third-party task: "bowl", a noisy quadratic cost Σ (θ_i − c_i)² with a known optimum.
// A task is your experiment: replace evaluate() by a call into your simulator or robot. Copy this file, rename
// the plugin and the component, and build it against an installed varbo (see CMakeLists.txt).
//
// Threads: varbo calls evaluate() on one thread, one trial after another (varbo/task.hpp), so a task may keep
// state such as a simulator or a device handle without locks.
#include <cmath>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <varbo/plugin.hpp>

namespace {

class Bowl final : public varbo::Task {
 public:
  Bowl(varbo::Vec center, varbo::Box box, std::string noise, double noise_std)
      : center_(std::move(center)), box_(std::move(box)), noise_(std::move(noise)), noise_std_(noise_std) {}

  varbo::Domain domain() const override {
    std::vector<std::string> names;
    for (varbo::Index i = 0; i < center_.size(); ++i) names.push_back(fmt::format("x{}", i + 1));  // fmt comes with varbo
    return {box_, names};
  }

  // θ arrives in user units (the box above); `rng` is this trial's own stream, so noise is reproducible.
  varbo::Evaluation evaluate(const varbo::Vec& theta, varbo::Rng& rng) override {
    varbo::Evaluation e;
    const double f = clean(theta);
    if (!std::isfinite(f)) {  // a failed trial is a result, not an exception: recorded, and BO learns from it
      e.ok = false;
      e.error = "the cost is not finite";
      return e;
    }
    double eps = 0;
    if (noise_ == "gaussian") eps = noise_std_ * rng.normal();
    if (noise_ == "student_t") eps = noise_std_ * student_t3(rng);
    // Named components are shown in trials.csv; their sum is the cost.
    e.components = {{"distance", f}, {"noise", eps}};
    e.cost = f + eps;
    e.noiseless_cost = f;  // only for regret figures of synthetic tasks; leave NaN for a real experiment
    ++trials_;             // state is safe here: never called concurrently
    return e;
  }

  std::vector<std::string> component_names() const override { return {"distance", "noise"}; }
  std::optional<varbo::Optimum> optimum() const override { return varbo::Optimum{0.0, {center_}}; }
  std::optional<double> noiseless_cost(const varbo::Vec& theta) const override { return clean(theta); }

 private:
  double clean(const varbo::Vec& theta) const { return (theta - center_).squaredNorm(); }
  static double student_t3(varbo::Rng& rng) {  // Student-t with 3 degrees of freedom: heavy-tailed noise
    double chi2 = 0;
    for (int k = 0; k < 3; ++k) chi2 += std::pow(rng.normal(), 2);
    return rng.normal() / std::sqrt(chi2 / 3);
  }

  varbo::Vec center_;
  varbo::Box box_;
  std::string noise_;
  double noise_std_;
  long trials_ = 0;
};

// The factory validates what the option declarations cannot express. Errors go through the option's node, so
// the user sees file:line:col and the key (e.g. "s.yaml:2:35: key 'task.center': expected 1 or 3 values, got 2").
std::unique_ptr<varbo::Task> make_bowl(const varbo::Options& o, const varbo::BuildContext&) {
  const long dim = o.integer("dim");  // opt::integer is read as long
  const std::vector<double> bounds = o.reals("bounds");
  if (bounds.size() != 2 || !(bounds[0] < bounds[1]))
    o.node("bounds").fail("expected [lower, upper] with lower < upper");
  varbo::Vec center = varbo::Vec::Constant(dim, 0.5 * (bounds[0] + bounds[1]));
  if (o.is_set("center")) {  // an optional list: declared with an empty default, so it may be unset
    const std::vector<double> c = o.reals("center");
    if (c.size() != 1 && c.size() != static_cast<std::size_t>(dim))
      o.node("center").fail(fmt::format("expected 1 or {} values, got {}", dim, c.size()));
    for (long i = 0; i < dim; ++i) center(i) = c.size() == 1 ? c[0] : c[static_cast<std::size_t>(i)];
    if ((center.array() < bounds[0]).any() || (center.array() > bounds[1]).any())
      o.node("center").fail("the center lies outside the bounds");
  }
  // A standard exception also works: varbo turns it into a config error naming this component (exit 2) at the
  // component's position rather than at the offending key, so prefer o.node("key").fail(...).
  const std::string noise = o.str("noise");  // opt::choice is read with str(); the value is one of the choices
  if (noise == "none" && o.given("noise_std") && o.real("noise_std") > 0)
    throw std::invalid_argument("noise_std is set but noise is 'none'");
  varbo::Box box{varbo::Vec::Constant(dim, bounds[0]), varbo::Vec::Constant(dim, bounds[1])};
  return std::make_unique<Bowl>(std::move(center), std::move(box), noise, o.real("noise_std"));
}

}  // namespace

VARBO_PLUGIN("template_task", "1.0.0", "Example third-party task") {
  registry.add(varbo::make_component<varbo::Task>(
      "bowl", "noisy quadratic Σ (θ_i − c_i)² over a box (template plugin)",
      {varbo::opt::integer("dim", 2, "number of dimensions").at_least(1).at_most(100),
       varbo::opt::reals("bounds", "[-1, 1]", "[lower, upper] of every dimension"),
       varbo::opt::reals("center", "", "the minimizer: one value for every dimension, or one per dimension "
                                       "(default: the middle of the box)"),
       varbo::opt::choice("noise", "gaussian", {"none", "gaussian", "student_t"}, "observation noise"),
       varbo::opt::real("noise_std", 0.01, "scale of the noise").at_least(0)},
      varbo::Factory<varbo::Task>(make_bowl)));
}

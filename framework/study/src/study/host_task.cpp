// The task `python` (varbo/host_task.hpp): the domain of a study varbo.minimize writes, evaluated by the host.
#include "varbo/host_task.hpp"

#include <fmt/format.h>

#include <cmath>
#include <string>

#include "varbo/option_set.hpp"
#include "varbo/plugin.hpp"

namespace varbo {

namespace {

class HostTask : public Task, public SpaceAware {
 public:
  HostTask(Domain domain, std::vector<ConfigNode> domain_keys, HostEvaluator evaluate,
           std::vector<std::string> components)
      : domain_(std::move(domain)),
        domain_keys_(std::move(domain_keys)),
        evaluate_(std::move(evaluate)),
        components_(std::move(components)) {}
  Domain domain() const override { return domain_; }
  std::vector<std::string> component_names() const override { return components_; }
  SharedSpace search_space() const override { return space_; }
  void set_search_space(SharedSpace space) override {
    // A second definition of the domain could only disagree with the parameters (as the external task).
    if (!domain_keys_.empty())
      domain_keys_.front().fail("the study declares `parameters:`, which define the names and the domain; remove this key");
    space_ = std::move(space);
    domain_ = Domain{space_->user_box(), space_->names()};
  }
  Evaluation evaluate(const Vec& theta, Rng& /*rng: the host owns its randomness*/) override {
    if (evaluate_) return evaluate_(theta, domain_.names, space_.get());
    Evaluation ev;
    ev.ok = false;
    ev.cost = std::nan("");
    ev.error = "the task 'python' evaluates only inside varbo.minimize(), which gives it the function";
    return ev;
  }

 private:
  Domain domain_;
  std::vector<ConfigNode> domain_keys_;
  SharedSpace space_;
  HostEvaluator evaluate_;
  std::vector<std::string> components_;
};

/// `components: [...]`: the cost components the function's dict answers carry (columns of trials.csv).
std::vector<std::string> declared_components(const Options& o) {
  return o.given("components") ? cost_component_names(o.node("components")) : std::vector<std::string>{};
}

std::unique_ptr<Task> make_host_task(const Options& o, HostEvaluator evaluate) {
  std::vector<ConfigNode> keys;
  for (const char* key : {"lower", "upper", "names"})
    if (o.given(key)) keys.push_back(o.node(key));
  if (keys.empty())  // the study's `parameters:` give the domain (set_search_space), or the study refuses it
    return std::make_unique<HostTask>(Domain{Box{Vec(0), Vec(0)}, {}}, std::move(keys), std::move(evaluate),
                                      declared_components(o));
  if (!o.given("lower") || !o.given("upper"))
    o.source().fail("expected lower and upper (one bound per parameter), or no box at all and the study's `parameters:`");
  const auto lower = o.reals("lower"), upper = o.reals("upper");
  if (lower.empty()) o.node("lower").fail("expected at least one value");
  if (lower.size() != upper.size())
    o.node("upper").fail(fmt::format("has {} entries but lower has {}", upper.size(), lower.size()));
  for (std::size_t i = 0; i < lower.size(); ++i)
    if (!(lower[i] < upper[i])) o.node("upper").fail(fmt::format("entry {} is not above lower[{}]", i, i));
  const auto d = static_cast<Index>(lower.size());
  Domain dom;
  dom.box = Box{Eigen::Map<const Vec>(lower.data(), d), Eigen::Map<const Vec>(upper.data(), d)};
  if (o.given("names")) {
    const ConfigNode n = o.node("names");
    if (!n.is_sequence() || static_cast<Index>(n.size()) != d)
      n.fail(fmt::format("expected a list of {} parameter names (one per bound)", d));
    // Distinct, non-empty names: the objective receives a dict by name, so a repeated name would hide a
    // dimension from it (`names: [a, a]` passed only the last value), as the external task refuses too.
    dom.names = distinct_names(n, "parameter");
  }
  for (Index i = static_cast<Index>(dom.names.size()); i < d; ++i) dom.names.push_back(fmt::format("x{}", i + 1));
  return std::make_unique<HostTask>(std::move(dom), std::move(keys), std::move(evaluate), declared_components(o));
}

}  // namespace

void add_host_python_task(Registry& registry, std::function<HostEvaluator()> evaluator_at_build) {
  ComponentInfo info = make_component<Task>(
      "python",
      "a Python function (varbo.minimize): the box lower..upper, parameters named by names, or the study's "
      "`parameters:`",
      {opt::reals("lower", "", "lower bound per parameter (leave the box out when the study declares `parameters:`)"),
       opt::reals("upper", "", "upper bound per parameter"),
       opt::node("names", "", "parameter names (default x1, x2, ...)"),
       opt::node("components", "",
                 "names of the cost components the function returns in {cost: c, components: {name: value}} "
                 "(columns of trials.csv; for `varbo rescore` and the dashboard)")},
      Factory<Task>([evaluator_at_build](const Options& o, const BuildContext&) {
        return make_host_task(o, evaluator_at_build ? evaluator_at_build() : HostEvaluator());
      }));
  info.plugin = "python";
  info.library = "<varbo Python module>";
  registry.add(std::move(info));
}

}  // namespace varbo

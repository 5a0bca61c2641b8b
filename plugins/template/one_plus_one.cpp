// Template for a third-party algorithm without a surrogate: "one_plus_one", the (1+1) evolution strategy with
// Rechenberg's 1/5 success rule (a child replaces its parent when it is better; the step grows by e^(1/3) on a
// success and shrinks by e^(-1/12) on a failure, which keeps it constant at a success rate of 1/5).
// Copy this file, rename the plugin and the component, and build it against an installed varbo.
//
// An algorithm works in ask/tell form on the unit cube: varbo maps θ to and from the task's units, runs the
// trials and records them. Threads: every method is called from one thread (varbo/algorithm.hpp).
// Determinism: ask() depends only on the seed and the ask/tell sequence, because `varbo run --resume` and
// `varbo study` rebuild the algorithm by replaying the stored trials (ask(1) then tell()).
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <varbo/plugin.hpp>

namespace {

class OnePlusOne final : public varbo::Algorithm {
 public:
  OnePlusOne(const varbo::Options& o, const varbo::BuildContext& ctx)
      : dim_(ctx.dim), sigma_(o.real("sigma")), rng_(varbo::Rng(ctx.seed).stream(0x1a1)) {
    const std::string start = o.str("start");  // opt::choice is read with str()
    if (start == "initial_point" && !ctx.initial_point)
      o.node("start").fail("the task and the study give no initial point; use start: center or random");
    if (start == "initial_point") start_ = *ctx.initial_point;
    else if (start == "random") start_ = rng_.uniform_vec(dim_);
    else start_ = varbo::Vec::Constant(dim_, 0.5);
  }

  std::vector<varbo::Suggestion> ask(varbo::Index q) override {
    std::vector<varbo::Suggestion> out;
    for (varbo::Index j = 0; j < q; ++j) {
      if (!parent_ && j == 0 && !started_) {  // the first trial is the start point
        out.push_back({start_, "initial", 0, 0});
        started_ = true;
        continue;
      }
      const varbo::Vec& from = parent_ ? *parent_ : start_;
      const varbo::Vec child = varbo::Box::unit(dim_).clamp(from + sigma_ * rng_.normal_vec(dim_));
      out.push_back({child, "mutation", 0, 0});
    }
    return out;
  }

  void tell(const std::vector<varbo::Observation>& observations) override {
    for (const varbo::Observation& obs : observations) {
      ++told_;
      // A failed trial (ok = false) has no cost: it counts as a worse child, so the step shrinks.
      const bool better = obs.ok && (!parent_ || obs.cost < parent_cost_);
      if (better) {
        parent_ = obs.x;
        parent_cost_ = obs.cost;
      }
      if (told_ > 1) sigma_ = std::clamp(sigma_ * std::exp(better ? 1.0 / 3.0 : -1.0 / 12.0), 1e-6, 0.5);
    }
  }

  // The θ to deploy: the best successful trial so far (varbo reports it in summary.json).
  std::optional<varbo::Vec> recommendation() const override { return parent_; }

  // Optional: one line per iteration in model.yaml (here the step size), written when `iteration` changes.
  std::optional<varbo::ModelSnapshot> snapshot() const override {
    varbo::ModelSnapshot s;
    s.iteration = told_;
    s.hyperparameters = {{"sigma", sigma_}};
    s.note = parent_ ? "parent cost " + std::to_string(parent_cost_) : "no successful trial yet";
    return s;
  }

 private:
  varbo::Index dim_;
  double sigma_;
  varbo::Rng rng_;  // one stream, drawn in ask(): the same seed and the same trials give the same run
  varbo::Vec start_;
  bool started_ = false;
  std::optional<varbo::Vec> parent_;
  double parent_cost_ = std::numeric_limits<double>::infinity();
  varbo::Index told_ = 0;
};

}  // namespace

VARBO_PLUGIN("template_algorithm", "1.0.0", "Example third-party algorithm without a surrogate") {
  registry.add(varbo::make_component<varbo::Algorithm>(
      "one_plus_one", "(1+1) evolution strategy with the 1/5 success rule; no model (template plugin)",
      {varbo::opt::real("sigma", 0.2, "initial step size, in fractions of the box").above(0).at_most(0.5),
       varbo::opt::choice("start", "center", {"center", "random", "initial_point"},
                          "first trial: the middle of the box, a random point, or the task's initial point")},
      varbo::Factory<varbo::Algorithm>([](const varbo::Options& o, const varbo::BuildContext& ctx) {
        return std::make_unique<OnePlusOne>(o, ctx);
      })));
}

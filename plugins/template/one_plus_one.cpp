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

#include <varbo/option_set.hpp>
#include <varbo/plugin.hpp>

namespace {

// The settings, with their defaults written once: the options below are bound to these fields (Ceres-style
// options struct), so `varbo plugins --describe one_plus_one` shows exactly these values.
struct OnePlusOneSettings {
  enum class Start { Center, Random, InitialPoint };
  double sigma = 0.2;             ///< initial step size, fractions of the box
  Start start = Start::Center;    ///< the first trial
};

const varbo::OptionSet<OnePlusOneSettings>& one_plus_one_options() {
  using S = OnePlusOneSettings;
  namespace opt = varbo::opt;
  // A function-local static: built on first use, not by a static initializer when the library is loaded.
  static const varbo::OptionSet<S> set{
      opt::real("sigma", &S::sigma, "initial step size, in fractions of the box").above(0).at_most(0.5),
      opt::choice("start", &S::start,
                  {{"center", S::Start::Center}, {"random", S::Start::Random}, {"initial_point", S::Start::InitialPoint}},
                  "first trial: the middle of the box, a random point, or the task's initial point")};
  return set;
}

class OnePlusOne final : public varbo::Algorithm {
 public:
  OnePlusOne(const OnePlusOneSettings& s, const varbo::Options& o, const varbo::BuildContext& ctx)
      : dim_(ctx.dim), sigma_(s.sigma), rng_(varbo::Rng(ctx.seed).stream(0x1a1)) {
    using Start = OnePlusOneSettings::Start;
    // o.node("key").fail(...) reports a bad value at its file:line:col.
    if (s.start == Start::InitialPoint && !ctx.initial_point)
      o.node("start").fail("the task and the study give no initial point; use start: center or random");
    if (s.start == Start::InitialPoint) start_ = *ctx.initial_point;
    else if (s.start == Start::Random) start_ = rng_.uniform_vec(dim_);
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
      one_plus_one_options().specs(),
      varbo::Factory<varbo::Algorithm>([](const varbo::Options& o, const varbo::BuildContext& ctx) {
        return std::make_unique<OnePlusOne>(one_plus_one_options().read(o), o, ctx);
      })));
}

// Template for a third-party acquisition, "greedy_mean", utility = −(E[y] + weight·s).
// Copy this file, rename the plugin and the component, and build it against an installed varbo (CMakeLists.txt).
// Threads: prepare() is called from one thread after each fit; evaluate() from many threads at once while the
// acquisition is optimized, so it reads only what prepare() stored (varbo/acquisition.hpp).
#include <varbo/plugin.hpp>

namespace {

class GreedyMean final : public varbo::Acquisition {
 public:
  explicit GreedyMean(double weight) : weight_(weight) {}
  void prepare(const varbo::AcquisitionContext& ctx) override { model_ = ctx.model; }
  double evaluate(const varbo::Vec& x, varbo::Vec* grad) const override {
    const varbo::Prediction p = model_->predict(x, grad != nullptr);
    const double s = p.total_std();
    if (grad) *grad = -(p.d_mean + weight_ * p.d_total_var() / (2 * s));
    return -(p.mean + weight_ * s);
  }

 private:
  double weight_;
  const varbo::Surrogate* model_ = nullptr;
};

}  // namespace

VARBO_PLUGIN("template", "1.0.0", "Example third-party plugin") {
  registry.add(varbo::make_component<varbo::Acquisition>(
      "greedy_mean", "pure exploitation of the posterior mean plus weight·s (template plugin)",
      {varbo::opt::real("weight", 0.0, "risk weight on the predictive standard deviation")},
      varbo::Factory<varbo::Acquisition>([](const varbo::Options& o, const varbo::BuildContext&) {
        return std::make_unique<GreedyMean>(o.real("weight"));
      }),
      {"acquisition:gradient"}));
}

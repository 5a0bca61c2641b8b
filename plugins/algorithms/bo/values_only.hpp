#pragma once
// An acquisition searched by its values only: the surrogate under it gives no gradients (docs/plugins.md).
#include "varbo/acquisition.hpp"

namespace varbo::bo {

/// A prepared acquisition offered by its values only (the surrogate under it gives no gradients).
class ValuesOnly final : public Acquisition {
 public:
  explicit ValuesOnly(const Acquisition& a) : a_(a) {}
  void prepare(const AcquisitionContext&) override {}
  double evaluate(const Vec& x, Vec*) const override { return a_.evaluate(x, nullptr); }
  bool has_gradient() const override { return false; }
  std::string state() const override { return a_.state(); }

 private:
  const Acquisition& a_;
};

}  // namespace varbo::bo

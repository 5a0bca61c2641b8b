// varbo._fit and varbo._Model: `varbo fit` (varbo/fit.hpp) on NumPy arrays, and the fitted model's predictions.
#include <fmt/format.h>

#include <cmath>
#include <memory>

#include "common.hpp"
#include "varbo/errors.hpp"
#include "varbo/fit.hpp"
#include "varbo/parallel.hpp"

namespace varbo::python {

namespace {

class PyModel {
 public:
  explicit PyModel(SurrogateFit fit) : fit_(std::move(fit)) {}

  py::dict predict(const py::object& X_in, bool gradients) const {
    Mat X = to_mat(X_in, "predict: X");
    if (X.cols() != dim_)
      throw InputError(fmt::format("predict: X has {} columns, the model was fitted on {}", X.cols(), dim_));
    if (!X.allFinite()) throw InputError("predict: X holds a NaN or infinite value");
    if (!fit_.model->ready()) throw NumericalError(fmt::format("predict: the model is not usable ({})", fit_.report.message));
    const Index n = X.rows();
    Vec mean(n), latent(n), noise(n), lnm(n), lnv(n);
    Mat d_mean, d_latent, d_noise;
    if (gradients) d_mean = d_latent = d_noise = Mat::Zero(n, X.cols());
    {
      ReleasedGil release;
      for (Index i = 0; i < n; ++i) {
        const Prediction p = fit_.model->predict(X.row(i).transpose(), gradients);
        mean[i] = p.mean;
        latent[i] = p.latent_var;
        noise[i] = p.noise_var();
        lnm[i] = p.log_noise_mean;
        lnv[i] = p.log_noise_var;
        if (gradients && p.has_gradient()) {
          d_mean.row(i) = p.d_mean.transpose();
          d_latent.row(i) = p.d_latent_var.transpose();
          d_noise.row(i) = p.d_noise_var().transpose();
        }
      }
    }
    py::dict out;
    out["mean"] = to_array(mean);
    out["latent_var"] = to_array(latent);
    out["noise_var"] = to_array(noise);
    out["log_noise_mean"] = to_array(lnm);
    out["log_noise_var"] = to_array(lnv);
    if (gradients) {
      out["d_mean"] = to_array(d_mean);
      out["d_latent_var"] = to_array(d_latent);
      out["d_noise_var"] = to_array(d_noise);
    }
    return out;
  }

  py::dict info() const {
    const FitReport& r = fit_.report;
    py::dict d;
    d["surrogate"] = fit_.component.info->full_name();
    d["optimized"] = r.optimized;
    d["ok"] = r.ok;
    d["objective"] = r.objective;
    d["objective_without_prior"] = r.log_likelihood;
    d["log_prior"] = r.log_prior;
    d["message"] = r.message;
    py::dict h;
    for (const auto& p : fit_.model->hyperparameters()) h[py::str(p.name)] = p.value;
    d["hyperparameters"] = h;
    py::dict st;
    for (const auto& [name, v] : fit_.model->state()) st[py::str(name)] = to_array(v);
    d["state"] = st;
    YAML::Emitter em;
    em << fit_.component.resolved();
    d["config"] = std::string(em.c_str());
    return d;
  }

  Index dim_ = 0;

 private:
  SurrogateFit fit_;
};

}  // namespace

void bind_fit(py::module_& m) {
  py::class_<PyModel>(m, "_Model", "A fitted surrogate; use varbo.fit().")
      .def("predict", &PyModel::predict, py::arg("X"), py::arg("gradients") = false)
      .def("info", &PyModel::info)
      .def_readonly("dim", &PyModel::dim_);
  m.def(
      "_fit",
      [](const std::string& yaml, const std::string& name, const py::object& X_in, const py::object& y_in,
         std::uint64_t seed, bool optimize, int threads) {
        Dataset data;
        data.X = to_mat(X_in, "fit: X");
        data.y = to_vec(y_in, "fit: y");
        if (data.X.rows() != data.y.size())
          throw InputError(fmt::format("fit: X has {} rows but y has {} values", data.X.rows(), data.y.size()));
        if (data.y.size() == 0) throw InputError("fit: no data; a model needs at least one (x, y) row");
        if (data.X.cols() == 0) throw InputError("fit: X has no columns");
        for (Index i = 0; i < data.y.size(); ++i)
          if (!data.X.row(i).allFinite() || !std::isfinite(data.y[i]))
            throw InputError(fmt::format("fit: row {} holds a NaN or infinite value (drop failed trials)", i));
        // As `varbo fit` refuses such a column (cmd_fit.cpp): the models square the values, and a fit of y·1e200
        // answered ok with infinite variances (red team, session 23).
        constexpr double kMaxMagnitude = 1e150;
        for (Index i = 0; i < data.X.rows(); ++i) {
          if (std::abs(data.y[i]) > kMaxMagnitude)
            throw InputError(fmt::format("fit: y[{}] = {} is too large in magnitude (at most {:g}: the models square "
                                         "it); rescale y",
                                         i, data.y[i], kMaxMagnitude));
          for (Index c = 0; c < data.X.cols(); ++c)
            if (std::abs(data.X(i, c)) > kMaxMagnitude)
              throw InputError(fmt::format("fit: X[{}, {}] = {} is too large in magnitude (at most {:g}); rescale X",
                                           i, c, data.X(i, c), kMaxMagnitude));
        }
        if (const double top = data.y.cwiseAbs().maxCoeff(); top > 0 && top < 1e-150)
          throw InputError(fmt::format("fit: every y is at most {:g} in magnitude: the models square it, which "
                                       "underflows below about 1e-154; rescale y (e.g. multiply by a constant)",
                                       top));
        const ConfigNode root = ConfigNode::parse(yaml, name);
        const Registry& registry = module_registry();
        // Resolving reads the registry (GIL held: load_plugin() cannot run meanwhile); the fit does not.
        const ConfigNode node = surrogate_node(root);
        registry.resolve(Kind::Surrogate, node);
        std::optional<SurrogateFit> fit;
        {
          ReleasedGil release;
          ThreadLimit limit(threads);
          fit.emplace(fit_surrogate(registry, node, data, seed, optimize, "fit"));
        }
        auto model = std::make_unique<PyModel>(std::move(*fit));
        model->dim_ = data.dim();
        return model;
      },
      py::arg("yaml"), py::arg("name"), py::arg("X"), py::arg("y"), py::arg("seed"), py::arg("optimize"),
      py::arg("threads"));
}

}  // namespace varbo::python

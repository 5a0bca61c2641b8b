// varbo._Algorithm: an algorithm component on the unit cube in ask/tell form, without a store (the Optuna sampler
// keeps its trials in Optuna's storage and tells them to a fresh algorithm when it needs a suggestion).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "common.hpp"
#include "varbo/errors.hpp"
#include "varbo/parallel.hpp"
#include "varbo/search_space_config.hpp"

namespace varbo::python {

namespace {

class PyAlgorithm {
 public:
  /// `parameters`: empty for the unit cube of dimension `dim`; else a `parameters:` list (YAML) of a typed space,
  /// and then points in and out are θ in user units (a category by its index), as a study's trials hold them.
  PyAlgorithm(const std::string& yaml, const std::string& name, Index dim, std::uint64_t seed, Index budget,
              int threads, const std::string& parameters)
      : dim_(dim), threads_(threads) {
    const Registry& registry = module_registry();
    const ResolvedComponent rc = registry.resolve(Kind::Algorithm, ConfigNode::parse(yaml, name));
    if (!parameters.empty()) {
      space_ = std::make_shared<const SearchSpace>(parse_search_space(ConfigNode::parse(parameters, "<parameters>")));
      const auto& provides = rc.info->provides;
      if ((space_->has_discrete()) &&
          std::find(provides.begin(), provides.end(), "search_space:mixed") == provides.end())
        throw ConfigError(fmt::format("{}: algorithm '{}' does not handle integer or categorical parameters (it lacks "
                                      "the capability 'search_space:mixed'); use bo, random or cma_es",
                                      rc.source.where(), rc.info->name));
      dim_ = space_->encoded_dim();
      theta_dim_ = static_cast<Index>(space_->size());
    } else {
      theta_dim_ = dim;
    }
    if (dim_ < 1) throw InputError(fmt::format("Algorithm: the dimension must be at least 1, got {}", dim_));
    BuildContext ctx;
    ctx.dim = dim_;
    ctx.seed = seed;
    ctx.budget = budget;
    alg_ = registry.create<Algorithm>(rc, ctx);
    if (space_)
      if (auto* aware = dynamic_cast<SpaceAware*>(alg_.get())) aware->set_search_space(space_);
  }

  py::tuple ask(Index q) {
    if (q < 1) throw InputError(fmt::format("ask: the batch size must be at least 1, got {}", q));
    std::vector<Suggestion> s;
    {
      ReleasedGil release;
      ThreadLimit limit(threads_);
      s = alg_->ask(q);
    }
    Mat X(static_cast<Index>(s.size()), theta_dim_);
    py::list phases;
    for (std::size_t i = 0; i < s.size(); ++i) {
      if (s[i].x.size() != dim_) throw Error("the algorithm suggested a point of the wrong dimension");
      const Vec x = Box::unit(dim_).clamp(s[i].x);
      // Typed: the admissible θ the study would record for this suggestion (study_impl.hpp, trial_x/theta_of).
      X.row(static_cast<Index>(i)) = (space_ ? space_->decode(space_->admissible(x)) : x).transpose();
      phases.append(s[i].phase);
    }
    return py::make_tuple(to_array(X), phases);
  }

  void tell(const py::object& X_in, const py::object& y_in) {
    const Mat X = unit_points(X_in, "tell: X");
    const Vec y = to_vec(y_in, "tell: y");
    if (y.size() != X.rows()) throw InputError(fmt::format("tell: X has {} rows but y has {} values", X.rows(), y.size()));
    std::vector<Observation> obs(static_cast<std::size_t>(X.rows()));
    for (Index i = 0; i < X.rows(); ++i) {
      Observation& o = obs[static_cast<std::size_t>(i)];
      o.x = X.row(i).transpose();
      o.ok = std::isfinite(y[i]);  // NaN: a failed trial
      o.cost = y[i];
    }
    ReleasedGil release;
    ThreadLimit limit(threads_);
    alg_->tell(obs);
  }

  void set_pending(const py::object& X_in) {
    const Mat X = unit_points(X_in, "set_pending: X");
    std::vector<Vec> p;
    for (Index i = 0; i < X.rows(); ++i) p.push_back(X.row(i).transpose());
    alg_->set_pending(p);
  }

  py::object recommendation() const {
    const auto r = alg_->recommendation();
    if (!r) return py::none();
    return to_array(space_ ? Vec(space_->decode(space_->admissible(*r))) : *r);
  }

 private:
  Mat unit_points(const py::object& X_in, const std::string& what) const {
    if (space_) {
      // θ rows in user units, each admissible, encoded as a study encodes its trials.
      Mat T = to_mat(X_in, what);
      if (T.rows() > 0 && T.cols() != theta_dim_)
        throw InputError(fmt::format("{}: {} columns, the space has {} parameters", what, T.cols(), theta_dim_));
      Mat X(T.rows(), dim_);
      for (Index i = 0; i < T.rows(); ++i) {
        const Vec t = T.row(i).transpose();
        std::string why;
        if (!space_->contains(t, &why)) throw InputError(fmt::format("{}: row {} is not admissible: {}", what, i, why));
        X.row(i) = space_->encode(t).transpose();
      }
      return X;
    }
    Mat X = to_mat(X_in, what);
    if (X.rows() > 0 && X.cols() != dim_)
      throw InputError(fmt::format("{}: {} columns, the algorithm has dimension {}", what, X.cols(), dim_));
    if (X.rows() == 0) X.resize(0, dim_);
    if (X.size() > 0 && !((X.array() >= -1e-12).all() && (X.array() <= 1 + 1e-12).all()))
      throw InputError(fmt::format("{}: points must lie in the unit cube [0, 1]^d", what));
    X = X.cwiseMax(0.0).cwiseMin(1.0);
    return X;
  }

  Index dim_;        ///< the algorithm's unit cube (the encoded dimension of a typed space)
  Index theta_dim_;  ///< columns of the points given and returned
  int threads_;
  SharedSpace space_;
  std::unique_ptr<Algorithm> alg_;
};

}  // namespace

void bind_algorithm(py::module_& m) {
  py::class_<PyAlgorithm>(m, "_Algorithm", "An algorithm on the unit cube, ask/tell without a store.")
      .def(py::init<const std::string&, const std::string&, Index, std::uint64_t, Index, int, const std::string&>(),
           py::arg("yaml"), py::arg("name"), py::arg("dim"), py::arg("seed"), py::arg("budget"), py::arg("threads") = 0,
           py::arg("parameters") = "")
      .def("ask", &PyAlgorithm::ask, py::arg("n") = 1)
      .def("tell", &PyAlgorithm::tell, py::arg("X"), py::arg("y"))
      .def("set_pending", &PyAlgorithm::set_pending, py::arg("X"))
      .def("recommendation", &PyAlgorithm::recommendation);
}

}  // namespace varbo::python

#include "rssgd.hpp"

#include <fmt/format.h>

#include <chrono>
#include <cmath>

#include "varbo/csv.hpp"
#include "varbo/errors.hpp"
#include "varbo/log.hpp"
#include "varbo/option_set.hpp"

namespace varbo::rssgd {

namespace {
// Purposes of the random streams: one stream per (purpose, step), so a step depends only on the seed and data.
enum Stream : std::uint64_t { kPerturb = 1, kFit = 2 };

const OptionSet<KappaPhase>& phase_options() {
  static const OptionSet<KappaPhase> set{
      opt::integer("steps", &KappaPhase::steps, "updates in this phase (0 = for the rest of the run)").at_least(0),
      opt::real("kappa", &KappaPhase::kappa, "risk factor κ in this phase (> 0 risk-averse, < 0 risk-seeking)")};
  return set;
}

// sigma and epsilon are declared here only: Settings holds what they become (a per-dimension σ, the radius).
const OptionSet<Settings>& option_set() {
  static const OptionSet<Settings> set{
      opt::real("sigma", 0.075, "perturbation std σ in the unit cube: z ~ N(0, σ²I) (paper: 0.075)").above(0),
      opt::reals("sigma_diag", "",
                 "per-dimension perturbation stds (unit cube), z ~ N(0, diag(σ_i²)); overrides sigma (natural "
                 "gradient, section 4.1.1)"),
      opt::real("eta", opt::nested(&Settings::step, &StepSize::eta), "step size η (paper: 0.5)").above(0),
      opt::real("step_min", opt::nested(&Settings::step, &StepSize::min),
                "lower bound of the scaled step η/r̃_θ (paper: 0.01)")
          .above(0),
      opt::real("step_max", opt::nested(&Settings::step, &StepSize::max),
                "upper bound of the scaled step η/r̃_θ (paper: 0.5)")
          .above(0),
      opt::real("cost_unit", &Settings::cost_unit,
                "the cost difference step_min and step_max refer to (η/r̃_θ ∈ [step_min, step_max] / cost_unit): "
                "-1 = the standard deviation of the critic's local costs, which makes the update independent of "
                "the cost's units; a number > 0 fixes it (1 = the paper's literal range, for costs of order 1)")
          .at_least(-1),
      opt::real("max_step", &Settings::max_step,
                "largest |Δθ| of one update in the unit cube (-1 = ε, the local data ball's radius: a longer step "
                "leaves every observation the critic was fitted on; 0 = no limit, as the paper)")
          .at_least(-1),
      opt::real("epsilon", -1, "radius ε of the local data ball in the unit cube (-1 = 3.5·max σ, as the paper)")
          .at_least(-1),
      opt::integer("neighbors", opt::nested(&Settings::neighborhood, &Neighborhood::k_nearest),
                   "> 0: use the k nearest observations instead of the ε-ball")
          .at_least(0),
      opt::integer("min_local_points", &Settings::min_fit_points,
                   "fit the critic on at least this many nearest observations; with fewer data no update is made")
          .at_least(2),
      opt::real("kappa", &Settings::kappa, "risk factor κ of eq. (19) (> 0 risk-averse, < 0 risk-seeking)"),
      opt::node("phases", "",
                "κ schedule: list of {steps: n, kappa: k}; the last phase may have steps: 0 (until the end); "
                "overrides kappa"),
      opt::component("critic", Kind::Surrogate, "{type: vhgp, restarts: 2}",
                     "local model of the cost distribution, refit on the local data every step"),
      opt::boolean("evaluate_initial", &Settings::evaluate_initial,
                   "execute θ0 itself in the first trial (gives the critic a point at θ)"),
      opt::reals("start", "", "θ0 in the unit cube (default: the study's initial_point, else the cube's centre)"),
      opt::path("history",
                "CSV of earlier observations (columns x1..xd in the unit cube and cost; a row whose cost is nan is a "
                "failed trial and is skipped), e.g. written by `varbo rescore --continue`"),
  };
  return set;
}
}  // namespace

std::vector<OptionSpec> options() { return option_set().specs(); }

Settings settings_from(const Options& o, Index dim) {
  Settings s = option_set().read(o);
  s.sigma = Vec::Constant(dim, o.real("sigma"));
  if (o.is_set("sigma_diag")) {
    const std::vector<double> v = o.reals("sigma_diag");
    if (static_cast<Index>(v.size()) != dim)
      o.node("sigma_diag").fail(fmt::format("expected {} values (one per dimension), got {}", dim, v.size()));
    for (double x : v)
      if (!(x > 0)) o.node("sigma_diag").fail("every perturbation std must be > 0");
    s.sigma = Eigen::Map<const Vec>(v.data(), dim);
  }
  if (s.step.min > s.step.max) o.node("step_min").fail("step_min must not exceed step_max");
  if (s.cost_unit != -1 && !(s.cost_unit > 0))
    o.node("cost_unit").fail("expected -1 (the local costs' standard deviation) or a cost difference > 0");
  // The sentinels are -1 exactly: 0 or -0.5 acted as -1 in silence while config.resolved.yaml kept the number
  // (red team, session 34).
  if (s.max_step != -1 && s.max_step < 0)
    o.node("max_step").fail("expected -1 (ε, the local data ball's radius), 0 (no limit) or a length > 0");
  const double eps = o.real("epsilon");
  if (eps != -1 && !(eps > 0)) o.node("epsilon").fail("expected -1 (3.5·max σ, as the paper) or a radius > 0");
  s.neighborhood.radius = eps > 0 ? eps : 3.5 * s.sigma.maxCoeff();  // paper: ε = 3.5σ
  s.neighborhood.min_points = s.min_fit_points;
  // k nearest below the fit's minimum never made an update: every trial perturbed θ0, in silence.
  if (s.neighborhood.k_nearest > 0 && s.neighborhood.k_nearest < s.min_fit_points)
    o.node("neighbors").fail(fmt::format("expected 0 (the ε-ball) or at least min_local_points ({}): the critic is "
                                         "fitted on at least that many observations, so with {} no update is ever made",
                                         s.min_fit_points, s.neighborhood.k_nearest));
  if (o.is_set("phases")) {
    ConfigNode list = o.node("phases");
    if (!list.is_sequence() || list.size() == 0) list.fail("expected a non-empty list of {steps: n, kappa: k}");
    for (std::size_t i = 0; i < list.size(); ++i) {
      ConfigNode item = list.item(i);
      if (!item.is_map()) item.fail("expected a map {steps: n, kappa: k}");
      const Options po =
          validate_options(item, phase_options().specs(), fmt::format("rssgd phase {}", i + 1), nullptr, {});
      const KappaPhase p = phase_options().read(po);
      if (p.steps == 0 && i + 1 < list.size())
        item.child("steps").fail("only the last phase may run until the end (steps: 0)");
      s.schedule.push_back(p);
    }
  }
  return s;
}

Rssgd::Rssgd(Settings settings, std::unique_ptr<Surrogate> critic, Vec start, std::uint64_t seed, Dataset history)
    : s_(std::move(settings)), critic_(std::move(critic)), theta_(std::move(start)), rng_(seed) {
  const Index d = theta_.size();
  if (d < 1) throw ConfigError("rssgd: the problem dimension must be at least 1");
  if (s_.sigma.size() != d) throw ConfigError("rssgd: sigma has the wrong dimension");
  if (!critic_) throw ConfigError("rssgd: no critic surrogate");
  theta_ = Box::unit(d).clamp(theta_);
  data_ = history.size() > 0 ? std::move(history) : Dataset::empty(d);
  if (data_.dim() != d) throw InputError(fmt::format("rssgd: history of dimension {}, expected {}", data_.dim(), d));
}

double Rssgd::kappa_at(Index step) const {
  if (kappa_override_ && step >= kappa_override_from_) return *kappa_override_;
  if (s_.schedule.empty()) return s_.kappa;
  Index start = 0;
  for (const KappaPhase& p : s_.schedule) {
    if (p.steps == 0 || step < start + p.steps) return p.kappa;
    start += p.steps;
  }
  return s_.schedule.back().kappa;
}

void Rssgd::set_kappa(double kappa) {
  kappa_override_ = kappa;
  kappa_override_from_ = steps_;
}

std::vector<Suggestion> Rssgd::ask(Index q) {
  std::vector<Suggestion> out;
  const Index d = theta_.size();
  for (Index j = 0; j < q; ++j) {
    Suggestion s;
    s.fit_seconds = j == 0 ? last_fit_seconds_ : 0.0;
    Pending p;
    if (s_.evaluate_initial && !asked_initial_ && !initial_elsewhere_) {
      asked_initial_ = true;
      p.x = theta_;
      p.initial = true;
      s.phase = "initial";
    } else {
      // Algorithm 3, step (a): z ~ N(0, diag(σ²)). A perturbation leaving the cube is clamped; tell() uses the
      // executed z = x − θ, so the update stays consistent with what was observed.
      // Draws handed out by other processes of the study (set_pending) are not repeated: their stream indices
      // are the next ones of the state this process and they share.
      Rng zr = rng_.stream(kPerturb, static_cast<std::uint64_t>(perturbations_++ + pending_elsewhere_));
      const Vec z = s_.sigma.cwiseProduct(zr.normal_vec(d));
      p.x = Box::unit(d).clamp(theta_ + z);
      s.phase = "rssgd";
    }
    s.x = p.x;
    pending_.push_back(p);
    out.push_back(std::move(s));
  }
  last_fit_seconds_ = 0;
  return out;
}

void Rssgd::set_pending(const std::vector<Vec>& pending) {
  initial_elsewhere_ = false;
  pending_elsewhere_ = 0;
  for (const Vec& p : pending) {
    const bool is_theta0 = p.size() == theta_.size() && (p - theta_).cwiseAbs().maxCoeff() <= 1e-12;
    if (s_.evaluate_initial && !asked_initial_ && !initial_elsewhere_ && is_theta0)
      initial_elsewhere_ = true;
    else
      ++pending_elsewhere_;
  }
}

void Rssgd::tell(const std::vector<Observation>& observations) {
  for (const Observation& o : observations) {
    Pending p;
    if (!pending_.empty()) {
      p = pending_.front();
      pending_.pop_front();
    } else {
      p.x = o.x;
      p.initial = true;  // not one of ours: data only
    }
    if (!o.ok || !std::isfinite(o.cost)) {
      // A failed perturbation counts in the update as a cost worse than any seen (cma_es ranks it last): θ moves
      // away from the direction that failed. Without an update θ stayed where every perturbation failed until
      // stop_after_failures ended the run (red team, session 27). Not added to the critic's data.
      if (!p.initial && data_.size() > 0 && o.x.size() == theta_.size() && o.x.allFinite()) {
        log_warn("rssgd: step {}: a failed trial counts in the update as a cost above every one seen", steps_);
        update_from(o, p, true);
      } else {
        log_warn("rssgd: a failed trial gives no update (no successful trial yet)");
      }
      if (!p.initial) ++steps_;
      continue;
    }
    if (o.x.size() != theta_.size())
      throw InputError(fmt::format("rssgd: observation of dimension {}, expected {}", o.x.size(), theta_.size()));
    data_.add(o.x, o.cost);  // Algorithm 3, step (c)
    if (p.initial) continue;
    update_from(o, p);
    ++steps_;
  }
}

void Rssgd::update_from(const Observation& o, const Pending&, bool failed) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::vector<Index> local = local_indices(data_.X, theta_, s_.neighborhood);
  if (static_cast<Index>(local.size()) < s_.min_fit_points) {
    log_info("rssgd: step {}: {} local observations (< {}); collecting data, no update", steps_, local.size(),
             s_.min_fit_points);
    return;
  }
  const Dataset ld = subset(data_, local);
  Rng fr = rng_.stream(kFit, static_cast<std::uint64_t>(steps_));
  const FitReport rep = critic_->fit(ld, fr);
  last_fit_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!rep.ok) log_warn("rssgd: critic fit at step {}: {}", steps_, rep.message);
  critic_ready_ = critic_->ready();
  if (!critic_ready_) {
    log_warn("rssgd: no usable critic at step {}; no update", steps_);
    return;
  }
  // Algorithm 3, steps (d)-(e), with the executed perturbation.
  const Vec z = o.x - theta_;
  const CriticEstimates est = query_critic(*critic_, theta_, o.x);
  // A failure's cost: above the worst seen and above the critic's estimate at θ by the costs' range (or r̃ when
  // they have none), so its advantage is positive and the step leads away from z whatever the critic extrapolates.
  const double range = data_.y.maxCoeff() - data_.y.minCoeff();
  const double cost = failed ? std::max(data_.y.maxCoeff(), est.mean_at_theta) +
                                   (range > 0 ? range : std::max(est.std_at_theta, 1e-12))
                             : o.cost;
  const double kappa = kappa_at(steps_);
  const double unit = s_.cost_unit > 0 ? s_.cost_unit : local_cost_unit(ld.y, advantage_of(cost, est, kappa));
  Vec delta = risk_sensitive_update(z, cost, est, kappa, s_.step, unit);
  if (!delta.allFinite()) {
    log_warn("rssgd: non-finite update at step {} (critic J~ {}, r~ {}); skipped", steps_, est.mean_at_theta,
             est.std_at_theta);
    return;
  }
  const double limit = s_.max_step < 0 ? s_.neighborhood.radius : s_.max_step;
  if (limit > 0 && delta.norm() > limit) {
    // The step would leave the data the critic was fitted on (a policy far from every trial on the next run). With
    // the paper's range (cost_unit 1) this is what costs far from order 1 do: say so once.
    if (!step_limit_warned_) {
      log_warn("rssgd: update {} would move θ by {:.3g} in the unit cube, beyond max_step {:.3g}; limited to it{}", steps_,
               delta.norm(), limit,
               s_.cost_unit > 0 ? fmt::format(" (with cost_unit {:g} the step range [step_min, step_max] is per {:g} of "
                                              "cost; the local costs spread {:.3g}: consider cost_unit: -1)",
                                              s_.cost_unit, s_.cost_unit, local_cost_unit(ld.y, 0.0))
                                : std::string());
      step_limit_warned_ = true;
    }
    delta *= limit / delta.norm();
  }
  theta_ = Box::unit(theta_.size()).clamp(theta_ + delta);
  ++updates_;
  snapshot_.iteration = data_.size();
  snapshot_.hyperparameters = critic_->hyperparameters();
  snapshot_.objective = rep.objective;
  snapshot_.note = fmt::format(
      "step {} kappa {} local {} J~ {:.6g} r~ {:.6g} r~z {:.6g} cost_unit {:.4g} step_size {:.4g} |dtheta| {:.4g}",
      steps_, kappa, local.size(), est.mean_at_theta, est.std_at_theta, est.std_at_perturbed, unit,
      scaled_step(s_.step, est.std_at_theta, unit), delta.norm());
  has_snapshot_ = true;
  log_debug("rssgd: {}", snapshot_.note);
}

std::optional<ModelSnapshot> Rssgd::snapshot() const {
  if (!has_snapshot_) return std::nullopt;
  return snapshot_;
}

Dataset read_history(const std::string& file, Index dim) {
  const CsvTable t = read_csv(file);
  const Index cost = t.column("cost");
  if (cost < 0) throw InputError(fmt::format("{}: no 'cost' column", file));
  Dataset out = Dataset::empty(dim);
  std::vector<Index> cols;
  for (Index i = 0; i < dim; ++i) {
    const Index c = t.column(fmt::format("x{}", i + 1));
    if (c < 0) throw InputError(fmt::format("{}: no column 'x{}' (θ in the unit cube)", file, i + 1));
    cols.push_back(c);
  }
  for (Index r = 0; r < t.values.rows(); ++r) {
    Vec x(dim);
    for (Index i = 0; i < dim; ++i) x[i] = t.values(r, cols[static_cast<std::size_t>(i)]);
    const double y = t.values(r, cost);
    const int line = t.lines[static_cast<std::size_t>(r)];
    if (std::isnan(y)) continue;  // a failed trial (rescore writes its cost as nan): no information on the cost
    // Anything else that is not a finite number is refused where it stands: NaN or inf in θ, an infinite cost or
    // one past ±1e150 (as `varbo fit` refuses them) were dropped or taken in silence (audit, session 45).
    for (Index i = 0; i < dim; ++i)
      if (!std::isfinite(x[i]))
        throw InputError(fmt::format("{}:{}: x{} = {}: expected a finite number in the unit cube [0, 1]", file, line,
                                     i + 1, x[i]));
    if (!(std::abs(y) <= 1e150))
      throw InputError(fmt::format("{}:{}: cost = {}: expected a finite number of magnitude at most 1e150 (nan "
                                   "marks a failed trial)", file, line, y));
    // θ in user units (trials.csv's columns have the same names) read as unit-cube points was accepted in silence.
    for (Index i = 0; i < dim; ++i)
      if (x[i] < -1e-9 || x[i] > 1 + 1e-9)
        throw InputError(fmt::format("{}:{}: x{} = {} is outside the unit cube [0, 1]: a history holds θ in the unit "
                                     "cube (as `varbo rescore --continue` writes it), not in the parameters' units",
                                     file, line, i + 1, x[i]));
    out.add(x, y);
  }
  return out;
}

}  // namespace varbo::rssgd

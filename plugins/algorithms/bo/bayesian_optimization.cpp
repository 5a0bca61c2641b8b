// bo: the run — construction, phases, the model fit, one suggestion (suggest), batches (ask), results (tell), the
// recommendation. Attempts and the final refinement: bo_attempts.cpp; rules that end an attempt early:
// bo_restart_rules.cpp; options: bo_options.cpp; saved state: bo_state.cpp.
#include "bayesian_optimization.hpp"
#include "component_outputs.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <set>
#include <mutex>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "acquisition_scale.hpp"
#include "bo_streams.hpp"
#include "pending_exclusion.hpp"
#include "values_only.hpp"
#include "varbo/errors.hpp"
#include "varbo/log.hpp"
#include "varbo/option_set.hpp"
#include "varbo/constrained_sampling.hpp"
#include "varbo/space_wrappers.hpp"
#include "varbo/side_cap.hpp"
#include "varbo/value_stall.hpp"

namespace varbo::bo {

namespace {
double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

BayesianOptimization::BayesianOptimization(const Options& o, const BuildContext& ctx)
    : dim_(ctx.dim), budget_(ctx.budget), rng_(ctx.seed) {
  if (dim_ < 1) throw ConfigError("bo: the problem dimension must be at least 1");
  const Registry& r = *ctx.registry;
  design_sampler_ = r.create<Sampler>(o.component("initial_design"), ctx);
  surrogate_ = r.create<Surrogate>(o.component("surrogate"), ctx);
  surrogate_name_ = o.component("surrogate").info->full_name();
  design_sampler_name_ = o.component("initial_design").info->full_name();
  region_name_ = o.component("region").info->full_name();
  region_ = r.create<RegionConstraint>(o.component("region"), ctx);
  {
    const auto& provides = o.component("region").info->provides;
    if (std::find(provides.begin(), provides.end(), "region:constraint") != provides.end()) {
      // A cautious region with a known-safe θ0 but a space-filling design: the first 2(d + 1) trials spread over
      // the whole box, unconstrained jumps on a robot, and nothing said it (audit, session 48).
      if (ctx.initial_point && o.component("initial_design").info->name != "around_initial_point")
        log_warn_once(fmt::format("bo: region '{}' keeps the search near the data, but the initial design '{}' "
                                  "spreads its points over the whole box, the given θ0 aside; for a cautious start "
                                  "around θ0 give `initial_design: {{type: around_initial_point}}` (docs/crbo.md)",
                                  region_name_, design_sampler_name_));
      observed_model_ = r.create<Surrogate>(o.component("surrogate"), ctx);
      // CRBO's region is a bound on the latent variance (Fröhlich 2021, eq. (6)): a surrogate that reports its
      // uncertainty as noise made it the whole box in silence (red team, session 30; docs/plugins.md).
      const auto& model_tags = o.component("surrogate").info->provides;
      if (std::find(model_tags.begin(), model_tags.end(), "surrogate:latent_variance") == model_tags.end())
        log_warn_once(fmt::format("bo: region '{}' bounds the surrogate's latent variance, and surrogate '{}' does "
                                  "not declare surrogate:latent_variance: if it reports its uncertainty as noise, "
                                  "the region is the whole box (docs/plugins.md, \"Writing a surrogate\")",
                                  o.component("region").info->full_name(), surrogate_name_));
    }
  }
  optimizer_ = r.create<Optimizer>(o.component("acquisition_optimizer"), ctx);
  optimizer_name_ = o.component("acquisition_optimizer").info->full_name();
  // The recommender's own instance: an optimizer may carry state from call to call (hit_and_run's chains), and
  // recommending must change no trial, also when a resumed run replays the trials without recommending.
  recommend_optimizer_ = r.create<Optimizer>(o.component("acquisition_optimizer"), ctx);
  refine_acquisition_ = r.create<Acquisition>(o.component("refine_acquisition"), ctx);
  refine_acquisition_name_ = o.component("refine_acquisition").info->full_name();
  std::shared_ptr<Acquisition> default_acq = r.create<Acquisition>(o.component("acquisition"), ctx);
  const BoSettings settings = bo_options().read(o);
  const double epsilon = settings.epsilon;
  refit_every_ = settings.refit_every;
  configured_refine_last_ = settings.refine_last >= 0 ? settings.refine_last : dim_ + 1;
  refine_last_ = configured_refine_last_;
  refine_early_ = settings.refine_early;
  refine_weighted_ = settings.refine_feasibility == "weight";
  refine_attempt_model_ = settings.refine_model != "all";
  refine_basin_ = settings.refine_model == "basin";
  refine_local_ = settings.refine_model == "local";
  batch_strategy_ = settings.batch_strategy;
  pending_distance_ = settings.pending_distance;
  initial_points_ = settings.initial_points >= 0 ? settings.initial_points : 2 * (dim_ + 1);
  if (budget_ > 0 && settings.initial_points < 0 && initial_points_ >= budget_)
    // Said: a study of one 10-choice categorical and one real (d = 11 coordinates) spent its budget of 20 on the
    // design in silence (red team, session 26).
    log_warn_once(fmt::format("bo: the default initial design, 2·(d + 1) = {} points for d = {} coordinates (a "
                              "categorical parameter has one per choice), takes the whole budget of {}: no trial is "
                              "model-based; give `initial_points:` or a larger budget",
                              initial_points_, dim_, budget_));
  if (budget_ > 0 && settings.initial_points >= budget_)  // equal: no model-based trial either (session 30)
    log_warn_once(fmt::format("bo: initial_points {} is {} the budget of {}: {}no trial is model-based",
                              settings.initial_points, settings.initial_points > budget_ ? "more than" : "all of",
                              budget_,
                              settings.initial_points > budget_ ? fmt::format("the design is cut to {} points and ",
                                                                              budget_)
                                                                : std::string()));
  if (budget_ > 0) initial_points_ = std::min(initial_points_, budget_);
  // The design is drawn whole, up front: 1e9 points ended in std::bad_alloc, exit 3, or the kernel's OOM killer
  // (red team, session 28). 5e7 coordinates are 400 MB; no model-based search starts after such a design.
  constexpr double kMaxDesignValues = 5e7;
  if (static_cast<double>(initial_points_) * static_cast<double>(dim_) > kMaxDesignValues)
    o.node("initial_points")
        .fail(fmt::format("{} points × {} coordinates is more than bo draws as a design ({:g} values); for a search "
                          "by design points alone use `algorithm: random` (it draws them one by one)",
                          initial_points_, dim_, kMaxDesignValues));
  if (settings.restart_points > initial_points_)
    log_warn_once(fmt::format("bo: restart_points {} is more than initial_points ({}): each fresh start draws {}",
                              settings.restart_points, initial_points_, initial_points_));
  configured_restart_points_ =
      settings.restart_points >= 0 ? std::min(settings.restart_points, initial_points_) : initial_points_;
  restart_points_ = configured_restart_points_;
  restart_away_ = settings.restart_design == "away";
  replicate_design_ = settings.replicate_design.value_or(surrogate_->tests_noise_on_replicates());
  failure_settings_ = parse_failure_model(o, &r);
  feasibility_ = std::make_unique<FeasibilityModel>(dim_);
  feasibility_->set_ard(failure_settings_.lengthscales == "ard");
  feasibility_->set_fit_failures(failure_settings_.fit_failures);

  if (o.is_set("phases")) {
    ConfigNode list = o.node("phases");
    if (!list.is_sequence() || list.size() == 0) list.fail("expected a non-empty list of phases");
    for (std::size_t i = 0; i < list.size(); ++i) {
      ConfigNode item = list.item(i);
      if (!item.is_map()) item.fail("expected a map: {evaluations: n, random: bool, acquisition: ..., epsilon: p}");
      Options po = validate_options(item, phase_options().specs(), fmt::format("phase {}", i + 1), &r, {});
      Phase p = phase_options().read(po);
      p.epsilon = po.real("epsilon") < 0 ? epsilon : po.real("epsilon");
      if (p.random && po.given("acquisition")) item.fail("a random phase takes no acquisition");
      if (p.random && po.real("epsilon") > 0)
        // Accepted in silence before: every point of a random phase is random already.
        log_warn_once(fmt::format("{}: phase {}: epsilon {} has no effect in a random phase (every point is random)",
                                  item.child("epsilon").where(), i + 1, po.real("epsilon")));
      if (!p.random)
        p.acquisition = po.given("acquisition") ? std::shared_ptr<Acquisition>(r.create<Acquisition>(po.component("acquisition"), ctx))
                                                : default_acq;
      p.name = p.random ? "random" : (po.given("acquisition") ? po.component("acquisition").info->name
                                                              : o.component("acquisition").info->name);
      p.acquisition_name = po.given("acquisition") ? po.component("acquisition").info->full_name()
                                                   : o.component("acquisition").info->full_name();
      if (p.evaluations == 0 && i + 1 < list.size())
        item.child("evaluations").fail("only the last phase may run until the budget is spent (evaluations: 0)");
      phases_.push_back(std::move(p));
    }
    // Phases the budget never reaches were accepted in silence (`budget: 8`, design 3, phases [20, 2]: the second
    // never ran).
    Index start = initial_points_;
    for (std::size_t i = 0; i < phases_.size(); ++i) {
      if (budget_ > 0 && start >= budget_) {
        log_warn_once(fmt::format(
            "bo: phase {}{} never runs: the initial design ({} trials) and the phases before it use the whole "
            "budget of {}",
            i + 1, i + 1 < phases_.size() ? fmt::format(" (and the {} after it)", phases_.size() - i - 1) : "",
            initial_points_, budget_));
        break;
      }
      start += phases_[i].evaluations;
    }
    // The last phase runs to the end of the budget whatever its `evaluations` (--describe bo says so); a count
    // written there that the budget exceeds was ignored in silence (audit, session 45: [2 random, 2 pi] with a
    // budget of 9 and a design of 3 ran pi for 4 trials).
    Index planned = initial_points_;
    for (const Phase& p : phases_) planned += p.evaluations;
    const ConfigNode last = list.item(list.size() - 1);
    if (budget_ > 0 && phases_.back().evaluations > 0 && planned < budget_ && last.has("evaluations"))
      log_warn_once(fmt::format("{}: the last phase runs until the budget is spent: its evaluations ({}) is not a "
                                "limit (the design and the phases plan {} trials of the budget's {}); add a phase "
                                "for the rest, or write evaluations: 0",
                                last.child("evaluations").where(), phases_.back().evaluations, planned, budget_));
  } else {
    Phase p;
    p.acquisition = default_acq;
    p.epsilon = epsilon;
    p.name = o.component("acquisition").info->name;
    p.acquisition_name = o.component("acquisition").info->full_name();
    phases_.push_back(std::move(p));
  }

  if (ctx.initial_point) initial_point_ = *ctx.initial_point;
  draw_initial_design();
  data_ = Dataset::empty(dim_);
  // Not its default: a stored study's configuration is the resolved one, which names every option.
  if (o.given("recommendation_kappa") && settings.recommendation_kappa != BoSettings{}.recommendation_kappa &&
      settings.recommendation != RecommendationRule::LowestBoundEvaluated)
    // Accepted in silence before: a user asking for a risk-averse recommendation got the default rule's.
    log_warn_once(fmt::format("{}: recommendation_kappa {} has no effect: it is the κ of `recommendation: "
                              "lowest_bound_evaluated`, and this run's rule is '{}'",
                              o.node("recommendation_kappa").where(), settings.recommendation_kappa,
                              o.str("recommendation")));
  if (failure_settings_.global_probe || failure_settings_.probe_every != 0)
    probe_model_ = r.create<Surrogate>(o.component("surrogate"), ctx);
  whole_box_ = std::make_unique<BoxRegion>(Box::unit(dim_));
  recommender_ = std::make_unique<Recommender>(settings.recommendation, settings.recommendation_kappa,
                                               r.create<Surrogate>(o.component("surrogate"), ctx));
  round_in_model_ = !o.is_set("discrete") || o.str("discrete") == "transform";
}

void BayesianOptimization::set_search_space(SharedSpace space) {
  if (told_ > 0 || fits_ > 0) throw std::logic_error("bo: set_search_space after the run started");
  if (!space || space->encoded_dim() != dim_)
    throw std::logic_error("bo: the search space's encoded dimension differs from the problem dimension");
  // Typed parameters (docs/search_space.md): the surrogate sees integers and categories rounded (unless
  // `discrete: relax`), the region keeps to the linear constraints; neither wrapper is there for a plain box.
  space_ = std::move(space);
  if (space_->has_constraints()) draw_initial_design();  // inside the constraints now that they are known
  const SharedSpace model_space = round_in_model_ ? space_ : nullptr;
  surrogate_ = respect_types(std::move(surrogate_), model_space);
  if (observed_model_) observed_model_ = respect_types(std::move(observed_model_), model_space);
  if (probe_model_) probe_model_ = respect_types(std::move(probe_model_), model_space);
  whole_box_ = respect_constraints(std::move(whole_box_), space_);
  region_ = respect_constraints(std::move(region_), space_);
  recommender_->wrap_model(model_space);
  // An integer parameter's cell in the unit cube: a point pending elsewhere (or earlier in the batch) is kept out
  // by at least half the widest one, so a suggestion that rounds onto it is searched again. With pending_distance
  // alone (1e-3) the check ran before rounding: [3,-2] three times in one batch of 6 on a 21×21 grid (red team,
  // session 30). Categories are not covered (their one-hot block rounds by its largest coordinate).
  const Vec base = space_->user_box().lower;
  for (std::size_t i = 0; i < space_->parameters().size(); ++i) {
    const Parameter& p = space_->parameters()[i];
    if (p.type != ParameterType::Int || p.high - p.low > 1000) continue;
    Vec a = base, b = base;
    for (double v = p.low; v < p.high; v += 1.0) {
      a[static_cast<Index>(i)] = v;
      b[static_cast<Index>(i)] = v + 1;
      // 0.6 of a step: the rounding boundary v + 0.5 lies up to 0.585 of the step from v on a log scale (1 → 2).
      const double step = (space_->encode(b) - space_->encode(a)).lpNorm<Eigen::Infinity>();
      integer_exclusion_ = std::max(integer_exclusion_, 0.6 * step);
    }
  }
}

const Phase& BayesianOptimization::phase_at(Index evaluation) const {
  Index start = initial_points_;
  for (const Phase& p : phases_) {
    if (p.evaluations == 0 || evaluation < start + p.evaluations) return p;
    start += p.evaluations;
  }
  return phases_.back();
}

Mat BayesianOptimization::starts_near(const Mat& seeds, const RegionConstraint& region, Rng& rng) const {
  // The seeds (usually the data) plus a feasible copy of each moved by N(0, 0.01²) per coordinate: at a data
  // point EI and PI are exactly flat (zero value, zero gradient), so a local optimizer started there alone
  // would never move.
  Mat out(2 * seeds.rows(), dim_);
  Index n = 0;
  for (Index i = 0; i < seeds.rows(); ++i) {
    out.row(n++) = seeds.row(i);
    const Vec moved = Box::unit(dim_).clamp(seeds.row(i).transpose() + 0.01 * rng.normal_vec(dim_));
    if (region.contains(moved)) out.row(n++) = moved.transpose();
  }
  return out.topRows(n);
}

std::optional<Vec> BayesianOptimization::best_feasible(const DifferentiableFunction& f, const Mat& starts) const {
  std::optional<Vec> best;
  double best_value = -std::numeric_limits<double>::infinity();
  for (Index i = 0; i < starts.rows(); ++i) {
    const Vec x = starts.row(i).transpose();
    if (!region_->contains(x)) continue;
    const double v = f.value(x, nullptr);
    if (!best || (std::isfinite(v) && v > best_value)) {  // a feasible start even when no value is finite
      best = x;
      if (std::isfinite(v)) best_value = v;
    }
  }
  return best;
}

Vec BayesianOptimization::evaluated_point(const Vec& x) const {
  const Vec c = Box::unit(dim_).clamp(x);
  return space_ ? space_->admissible(c) : c;
}

void BayesianOptimization::draw_initial_design() {
  Rng drng = rng_.stream(kDesign);
  design_ = initial_points_ > 0 ? design_sample(initial_points_, drng) : Mat(0, dim_);
  if (initial_point_ && design_.rows() > 0) design_.row(0) = initial_point_->transpose();
  if (replicate_design_ && design_.rows() >= 2) design_.row(design_.rows() - 1) = design_.row(0);
}

Mat BayesianOptimization::design_sample(Index n, Rng& rng) const {
  return check_sampler_outputs(sample_unit_cube(*design_sampler_, design_sampler_name_, space_, dim_, n, rng),
                               design_sampler_name_, n, dim_, false);
}

Vec BayesianOptimization::random_point(Rng& rng) const {
  // The region may hold no point the sampler finds (fewer_ok); the unit cube always does.
  Mat m = check_sampler_outputs(sample_named(*design_sampler_, design_sampler_name_, *region_, 1, rng),
                                design_sampler_name_, 1, dim_, true);
  if (m.rows() == 0)
    m = check_sampler_outputs(sample_named(*design_sampler_, design_sampler_name_, BoxRegion(Box::unit(dim_)), 1, rng),
                              design_sampler_name_, 1, dim_, false);
  return m.row(0).transpose();
}

bool BayesianOptimization::fit_feasibility(FeasibilityModel& model) const {
  // Successes (the real data, not batch fantasies) and failures, in one design matrix.
  const Index n = data_.size(), m = static_cast<Index>(failed_.size());
  if (n + m == 0) return false;
  Mat X(n + m, dim_);
  std::vector<bool> success(static_cast<std::size_t>(n + m), true);
  if (n > 0) X.topRows(n) = data_.X;
  for (Index i = 0; i < m; ++i) {
    X.row(n + i) = failed_[static_cast<std::size_t>(i)].transpose();
    success[static_cast<std::size_t>(n + i)] = false;
  }
  const Vec ell = cost_lengthscales(model_ready_ ? surrogate_->hyperparameters() : Hyperparameters{}, dim_);
  // P(success) where nothing is known = the smoothed success rate of the initial design: a space-filling sample
  // of the domain estimates the feasible share of it, while later trials are concentrated by the optimizer where
  // it is good (and feasible), so counting them would make unexplored regions look safer than they are.
  if (design_told_ > 0)
    model.set_prior_success_rate((static_cast<double>(design_told_ - design_failed_) + 1.0) /
                                 (static_cast<double>(design_told_) + 2.0));
  return model.fit(X, success, ell);
}

bool BayesianOptimization::update_feasibility(Index k, bool refit) {
  if (!failure_settings_.active(static_cast<Index>(failed_.size()))) return feasibility_on_ = false;
  if (!refit && feasibility_on_) return true;
  const Index n = data_.size(), m = static_cast<Index>(failed_.size());
  const bool was_on = feasibility_on_;
  feasibility_on_ = n + m > 0 && fit_feasibility(*feasibility_);
  // Never stricter than 0.8 × the probability of success where nothing is known (the smoothed success rate):
  // in a study where most trials fail, unexplored regions stay open while failed neighbourhoods are excluded.
  if (feasibility_on_) {
    exclusion_threshold_ = std::min(failure_settings_.min_probability, 0.8 * feasibility_->prior_probability());
    // A min_probability above that cap had no effect at all, in silence (red team, session 31: 0.95 ran the very
    // trials of the default): said once per process.
    if (exclusion_threshold_ < failure_settings_.min_probability &&
        failure_settings_.min_probability != FailureModelSettings{}.min_probability)  // a value the user chose
      log_warn_once(fmt::format(
          "bo: failure_model.min_probability {} is above 0.8 × the initial design's success rate ({:.3g}); θ with "
          "P(success) ≥ {:.3g} stay open, so that regions nothing is known about are not closed",
          failure_settings_.min_probability, 0.8 * feasibility_->prior_probability(), exclusion_threshold_));
  }
  if (!feasibility_on_) {
    log_warn("bo: trial {}: the failure model could not be fitted; failed trials are ignored this time", k);
  } else if (!was_on) {
    log_info("bo: trial {}: {} of {} trials failed; weighting the acquisition by P(success)", k, m, n + m);
  }
  return feasibility_on_;
}

Vec BayesianOptimization::random_point_avoiding_failures(Rng& rng) const {
  if (!feasibility_on_) return random_point(rng);
  // A θ that failed is never drawn again: where nearly every trial failed, the exclusion threshold follows the low
  // success rate down (update_feasibility) and a failed θ could pass it.
  const auto failed_here = [this](const Vec& x) {
    const Vec e = evaluated_point(x);
    for (const Vec& f : failed_)
      if ((evaluated_point(f) - e).lpNorm<Eigen::Infinity>() <= 1e-9) return true;
    return false;
  };
  Vec best;
  double best_p = -1;
  for (int i = 0; i < 64; ++i) {
    Vec x = random_point(rng);
    if (failed_here(x)) continue;
    const double p = feasibility_->probability(evaluated_point(x));
    if (p >= exclusion_threshold_) return x;
    if (p > best_p) {
      best_p = p;
      best = std::move(x);
    }
  }
  if (best.size() == dim_) return best;
  // The design sampler may have one point only: around_initial_point gives θ0 first, every time, and a failing θ0
  // was run again on every remaining trial (red team, session 26). Uniform points of the region then.
  const Box& box = region_->bounds();
  const auto consider = [&](const Vec& x) {
    if (!region_->contains(x) || failed_here(x)) return false;
    const double p = feasibility_->probability(evaluated_point(x));
    if (p >= exclusion_threshold_) return true;
    if (p > best_p) best_p = p, best = x;
    return false;
  };
  for (int i = 0; i < 256; ++i) {
    const Vec x = box.lower + (box.upper - box.lower).cwiseProduct(rng.uniform_vec(dim_));
    if (consider(x)) return x;
  }
  // A confidence region in 10 or more dimensions is a sliver of its box: none of the 256 uniform points fell in it,
  // and the design sampler's θ0 — the one that had failed — was returned, run after run until stop_after_failures
  // (audit, session 48: d = 10, trials 7–15 all at θ0). Points around the region's seeds (its data) then, at
  // shrinking steps.
  const Mat seeds = region_->seeds();
  for (int i = 0; i < 256 && seeds.rows() > 0; ++i) {
    const Vec s = seeds.row(i % seeds.rows()).transpose();
    const double step = 0.1 * std::ldexp(1.0, -(i / 64));
    const Vec x = box.clamp(s + step * box.width().cwiseProduct(rng.normal_vec(dim_)));
    if (consider(x)) return x;
  }
  if (best.size() == dim_) return best;
  const Vec fallback = random_point(rng);
  if (!failed_here(fallback)) return fallback;
  // Every draw failed before or lies outside the region: a known success inside it (measured again; a spent trial,
  // not a fall) rather than a known failure.
  Index chosen = -1;
  double chosen_p = -1;
  for (Index r = 0; r < data_.size(); ++r) {
    const Vec x = data_.X.row(r).transpose();
    if (!region_->contains(x)) continue;
    const double p = feasibility_->probability(evaluated_point(x));
    if (p > chosen_p) chosen_p = p, chosen = r;
  }
  return chosen >= 0 ? Vec(data_.X.row(chosen).transpose()) : fallback;
}

void BayesianOptimization::fit_model(Index k, const Dataset& data) {
  Rng frng = rng_.stream(kFit, static_cast<std::uint64_t>(k));
  const FitReport rep =
      (fits_ % refit_every_ == 0 || !model_ready_) ? surrogate_->fit(data, frng) : surrogate_->condition(data);
  ++fits_;
  if (!rep.ok) log_warn("bo: surrogate fit at trial {}: {}", k, rep.report());
  if (rep.ok || surrogate_->ready()) model_ready_ = surrogate_->ready();
  snapshot_.iteration = k;
  snapshot_.hyperparameters = surrogate_->hyperparameters();
  snapshot_.objective = rep.objective;
  // A failed fit's reason, or what an ok fit reports (the gp's kernel choice with kernel_candidates, a jitter).
  snapshot_.note = rep.message;
}
const Surrogate* BayesianOptimization::region_model(Index k, const Dataset& data) {
  if (!observed_model_ || data.size() <= data_.size()) return surrogate_.get();
  const std::pair<Index, Index> key{data_.size(), fits_};
  if (observed_model_key_ == key && observed_model_->ready()) return observed_model_.get();
  observed_model_key_ = {-1, -1};
  const Dataset observed = model_data_of(data_);
  try {
    // The observed rows come first in the fantasized data (recommender.hpp).
    take_fitted_hyperparameters(*surrogate_, *observed_model_, observed.size());
    const FitReport rep = observed_model_->condition(observed);
    if (rep.ok && observed_model_->ready()) {
      observed_model_key_ = key;
      return observed_model_.get();
    }
    log_warn("bo: trial {}: the region's model of the observations: {}; using the batch's model", k, rep.report());
  } catch (const std::exception& e) {
    log_warn("bo: trial {}: the region's model of the observations: {}; using the batch's model", k, e.what());
  }
  return surrogate_.get();
}

double BayesianOptimization::lie(const Vec& x) const {
  // Ginsbourger, Le Riche & Carraro 2010, "Kriging is well-suited to parallelize optimization", section 3:
  // kriging believer = the posterior mean; constant liar = one constant (min or mean of the observed costs).
  const double fallback = data_.size() ? data_.y.mean() : 0.0;
  switch (batch_strategy_) {
    case BatchStrategy::KrigingBeliever: return model_ready_ ? surrogate_->predict(x, false).mean : fallback;
    case BatchStrategy::ConstantLiarMin: return data_.size() ? data_.y.minCoeff() : 0.0;
    case BatchStrategy::ConstantLiarMean: return fallback;
  }
  return fallback;
}

void BayesianOptimization::set_pending(const std::vector<Vec>& pending) {
  for (const Vec& p : pending)
    if (p.size() != dim_) throw InputError(fmt::format("bo: pending point of dimension {}, expected {}", p.size(), dim_));
  pending_ = pending;
}

Suggestion BayesianOptimization::suggest(Index k, const Dataset& data, bool refit) {
  Suggestion s;
  if (k < design_.rows()) {
    s.x = design_.row(k).transpose();
    s.phase = "initial";
    return s;
  }
  const Phase& phase = phase_at(k);
  const auto uk = static_cast<std::uint64_t>(k);
  if (failure_settings_.replace_design && k < design_.rows() + design_failed_ && design_told_ == design_.rows() &&
      data.size() > 0 && update_feasibility(k, refit)) {
    // A failed design point gave the cost model nothing: replace it, where success is likely and far from the
    // design's successes (space-filling), so the first model sees as many points as a run without failures
    // (docs/failures.md).
    Rng rr = rng_.stream(kRandom, uk);
    std::vector<Vec> away;
    for (Index i = 0; i < data_.size(); ++i) away.push_back(data_.X.row(i).transpose());
    // At least as likely to succeed as an unexplored point (the design's success rate): a replacement is there
    // to inform the cost model, not to explore the failure boundary.
    s.x = feasible_point_away(rr, away, std::max(exclusion_threshold_, feasibility_->prior_probability()));
    s.phase = "replace";
    return s;
  }
  if (phase.random) {
    Rng rr = rng_.stream(kRandom, uk);
    update_feasibility(k, refit);
    s.x = random_point_avoiding_failures(rr);
    s.phase = "random";
    return s;
  }
  // Real results, not `data`: with fewer than 2 of them, the rest of a batch (several workers starting on a fresh
  // study, a first `suggest --batch` beyond the design, a design that all failed) came from a model of made-up
  // costs (pending points at 0 or at the one result): every gain at its maximum, CRBO's region the whole box
  // (red team, session 30). The design sampler's draws instead, as for one worker.
  if (data_.size() < 2) {
    Rng rr = rng_.stream(kRandom, uk);
    update_feasibility(k, refit);
    s.x = random_point_avoiding_failures(rr);
    s.phase = "random";
    log_info("bo: fewer than 2 successful trials; choosing trial {} at random", k);
    return s;
  }
  // After a fresh start of the region (TuRBO's restart, Eriksson 2019, section 2): first a new design, then a
  // model of the observations since the restart only, so the search is not drawn back to the old basin.
  auto* fresh_region = dynamic_cast<FreshStartRegion*>(region_.get());
  // The last refine_last trials of the budget refine the best basin found (minimizing the posterior mean by
  // default) instead of starting or continuing an attempt.
  const bool final_stretch = fresh_region && budget_ > 0 && k >= budget_ - refine_last_;
  if (fresh_starts_ > 0 && final_stretch && !refining_) {
    if (refinement_waits(k, data))
      log_debug("bo: trial {}: the final refinement waits: the current attempt still improves", k);
    else
      begin_refinement(k, data);
  }
  // refine_early: once fewer trials remain than a fresh start's design, no later attempt could begin and be
  // followed up; if the current attempt (past its design) holds the incumbent of all the data, the refinement
  // begins now instead of EI probing the rest of its trust region (Hartmann-6 seed 13: a basin found at trial 80
  // polished to 7.6e-07 instead of 2.9e-06; docs/defaults.md). An attempt that does not hold the incumbent goes on
  // until the last refine_last trials: it may still find a better basin.
  if (refine_early_ && fresh_region && budget_ > 0 && fresh_starts_ > 0 && !refining_ &&
      k >= budget_ - restart_points_ && k - fresh_trial_ >= restart_points_ && data.size() > fresh_from_) {
    Index best = 0;
    data.y.minCoeff(&best);
    if (best >= fresh_from_) begin_refinement(k, data);
  }
  if (fresh_starts_ > 0 && !refining_ && k - fresh_trial_ < restart_points_) follow_global_probe(k);

  if (fresh_starts_ > 0 && !refining_ && k - fresh_trial_ < restart_points_) {
    s.x = fresh_design_point(k, refit);
    s.phase = probe_trial_ == k ? "probe" : "restart";
    return s;
  }
  if (fresh_region && !refining_ && !final_stretch && refit)
    if (const std::optional<Index> probe = probe_to_follow(k, data, refit)) {
      Rng follow_rng = rng_.stream(kOptimize, uk * 2 + 1);
      follow_probe(k, *probe, data, follow_rng);
    }
  const Dataset chosen = model_data_of(data);
  const Dataset* model_data = &chosen;
  const auto t_fit = std::chrono::steady_clock::now();
  FitReport rep;
  if ((refit || !model_ready_) && !prefitted_) {  // a batch that started in the initial design fits here
    fit_model(k, *model_data);
  } else {
    rep = surrogate_->condition(*model_data);  // batch: condition on fantasized data, keep hyperparameters
  }
  s.fit_seconds = seconds_since(t_fit);
  if (!model_ready_) {
    Rng rr = rng_.stream(kRandom, uk);
    update_feasibility(k, refit);
    s.x = random_point_avoiding_failures(rr);
    s.phase = "random";
    log_warn("bo: no usable model at trial {}; choosing at random", k);
    return s;
  }
  const auto t_acq = std::chrono::steady_clock::now();
  Rng region_rng = rng_.stream(kOptimize, uk * 2 + 1);
  // failure_model.stall_value: once trials have failed, an attempt converged in value hands over sooner.
  ValueStall region_rule;  // the rule this update uses (restored after repeat_distance's fantasy updates)
  if (auto* value_stall = dynamic_cast<ValueStallRegion*>(region_.get());
      value_stall && failure_settings_.stall_value > 0 && !failed_.empty() &&
      failure_settings_.active(static_cast<Index>(failed_.size()))) {
    ValueStall& rule = region_rule;
    const bool late = budget_ > 0 && ((failure_settings_.stall_remaining > 0 &&
                                       budget_ - k < failure_settings_.stall_remaining) ||
                                      (failure_settings_.stall_attempt && budget_ - k < k - fresh_trial_));
    rule.fraction = late ? 0.0 : failure_settings_.stall_value;
    rule.scale = failure_settings_.stall_scale == "range" ? ValueStall::Scale::Range
                 : failure_settings_.stall_scale == "std" ? ValueStall::Scale::Std
                 : failure_settings_.stall_scale == "recent" ? ValueStall::Scale::Recent
                                                          : ValueStall::Scale::Best;
    rule.strict = failure_settings_.stall_strict;
    rule.incumbent = failure_settings_.stall_incumbent;
    value_stall->set_value_stall(rule);
  }
  // failure_model.length_max: once trials have failed, the trust region grows no larger (item 14).
  if (auto* capped = dynamic_cast<SideCapRegion*>(region_.get())) {
    const bool cap = failure_settings_.length_max > 0 && !failed_.empty() &&
                     failure_settings_.active(static_cast<Index>(failed_.size()));
    capped->set_side_cap(cap ? failure_settings_.length_max : std::numeric_limits<double>::infinity());
  }
  force_region_failures(k);
  {
    const Surrogate* rmodel = region_model(k, data);
    // Its seeds (hit-and-run chains start at the data) are observations too.
    const bool observed_only = rmodel != surrogate_.get();
    region_->update(rmodel, observed_only ? model_data_of(data_) : data, region_rng);
    check_region_outputs(*region_, region_name_, dim_);
  }
  Dataset late_refined;
  if (fresh_region && !refining_ && fresh_region->fresh_starts() > fresh_starts_ && restart_points_ > 0 &&
      final_stretch) {
    // Converged within the last trials: a new design could not be followed up; the refinement begins now, on its
    // model.
    fresh_starts_ = fresh_region->fresh_starts();
    begin_refinement(k, data);
    if (refine_attempt_model_) late_refined = refinement_data(data);
    model_data = late_refined.size() >= 2 ? &late_refined : &data;
    fit_model(k, *model_data);
    region_->update(surrogate_.get(), data, region_rng);
    check_region_outputs(*region_, region_name_, dim_);
  }
  if (fresh_region && !refining_ && fresh_region->fresh_starts() > fresh_starts_ && restart_points_ > 0) {
    remember_if_blocked(k, data);
    begin_fresh_attempt(k, fresh_region->fresh_starts(), data);
    log_info("bo: trial {}: the region restarts afresh ({}): a new design of {} points, then a model of the new "
             "points", k, fresh_starts_, restart_points_);
    s.x = fresh_design_point(k, refit);
    s.phase = probe_trial_ == k ? "probe" : "restart";
    s.acquisition_seconds = seconds_since(t_acq);
    return s;
  }
  if (refit) {
    // The region's state (e.g. CRBO's cautiousness report, Fröhlich 2021 section 4.1) goes to the log and,
    // via the snapshot, to model.yaml of the run.
    snapshot_.region_state = region_->state();
    if (!snapshot_.region_state.empty()) {
      if (region_->has_constraint()) {
        log_info("bo: trial {} region: {}", k, snapshot_.region_state);
      } else {
        log_debug("bo: trial {} region: {}", k, snapshot_.region_state);
      }
    }
  }
  const bool weighted = update_feasibility(k, refit);
  Rng erng = rng_.stream(kEpsilon, uk);
  if (phase.epsilon > 0 && erng.uniform() < phase.epsilon) {
    s.x = random_point_avoiding_failures(erng);
    s.phase = "epsilon";
    s.acquisition_seconds = seconds_since(t_acq);
    return s;
  }
  Rng arng = rng_.stream(kAcquisition, uk);
  AcquisitionContext actx{surrogate_.get(), model_data, k, &arng};
  // The final refinement exploits: by default the posterior mean's minimum in the small box (κ = 0).
  Acquisition& base = refining_ ? *refine_acquisition_ : *phase.acquisition;
  // Sizes and values checked at one point before the acquisition and its optimizer use them in bulk (a wrong
  // gradient length was undefined behaviour there): the surrogate before the acquisition reads its gradients, the
  // acquisition before the failure and pending wrappers do.
  const Vec probe = Vec::Constant(dim_, 0.5);
  bool model_gradients = true;
  if (surrogate_->ready()) {
    const Prediction at_centre = check_surrogate_outputs(*surrogate_, surrogate_name_, probe, dim_);
    model_gradients = at_centre.d_mean.size() == dim_;
    // A NaN or negative variance was used silently (red team, session 23): said here, once per trial.
    if (const std::string bad = unusable_prediction(at_centre); !bad.empty())
      log_warn("bo: trial {}: surrogate '{}' predicts {} at the centre of the domain; the acquisition may find no "
               "usable point", k, surrogate_name_, bad);
    if (const Surrogate& scored = surrogate_->acquisition_model(); &scored != surrogate_.get())
      check_surrogate_outputs(scored, surrogate_name_ + " (its acquisition model)", probe, dim_);
  }
  base.prepare(actx);
  // Without the model's gradients the acquisition's gradient is not asked for, here or below.
  const ValuesOnly base_values(base);
  check_acquisition_outputs(model_gradients ? static_cast<const Acquisition&>(base) : base_values,
                            refining_ ? refine_acquisition_name_ : phase.acquisition_name, probe, dim_);
  // With failures seen, maximize the acquisition weighted by P(success) (failure_aware.hpp). The final refinement
  // around the incumbent (a success) only excludes likely failures: weighting pulled its points away from a
  // failure boundary beside the minimizer (docs/defaults.md).
  std::unique_ptr<FeasibilityWeightedAcquisition> feasible;
  double p_min = exclusion_threshold_;
  std::ptrdiff_t refine_failures = 0;  // failure_model.refine_backoff: failed trials of the refinement so far
  Index failure_streak = 0;            // failure_model.streak_backoff: the failures in a row it counted
  if (weighted && (refining_ || failure_settings_.incumbent_level != "refinement") && data_.size() > 0) {
    // Success as likely as at the incumbent (up to refine_min_probability), not merely more likely than failure:
    // the refinement's mean minimum beside a failure boundary otherwise lay on the P = min_probability contour
    // and every other refinement trial failed; applied to every trial (incumbent_level: always) it halved
    // Hartmann-6's failures and its stuck runs fell from 8 to 6 of 20 (docs/failures.md).
    Index best = 0;
    data_.y.minCoeff(&best);
    const double p_incumbent = feasibility_->probability(data_.X.row(best).transpose());
    // incumbent_level: fixed (session fail13): outside the refinement the level is not lowered to the incumbent's
    // P, so an attempt cannot ratchet along a failure boundary (each new best a little closer, its lower P opening
    // the next step: Hartmann-3 with a ball, docs/failures.md).
    const bool fixed = failure_settings_.incumbent_level == "fixed" && !refining_;
    p_min = std::max(p_min, fixed ? failure_settings_.refine_min_probability
                                  : std::min(failure_settings_.refine_min_probability, p_incumbent));
    if (!refining_ && !fresh_region && failure_settings_.streak_backoff) {
      // failure_model.streak_backoff (session 46; docs/failures.md, item 17): a region without attempts (box,
      // confidence) has no failure_run to end a streak, and the level followed the incumbent's P down with each
      // failure beside it (0.8 → 0.73 → 0.68 → … → 0.5): region box, seed 2 of a ball failure next to the
      // optimum, 7 falls in a row within 0.003 of each other. As the refinement's backoff: each failure in a row
      // halves the probability of failure accepted.
      const Index streak = failed_in_a_row(k);
      failure_streak = streak;
      if (streak > 0)
        p_min = 1.0 - (1.0 - p_min) * std::ldexp(1.0, -static_cast<int>(std::min<Index>(streak, 60)));
    }
    if (refining_ && failure_settings_.refine_backoff && refine_trial_ >= 0) {
      // failure_model.refine_backoff (session 42; docs/failures.md, item 13): the incumbent's P falls with every
      // failure beside it, and with it the level, so a refinement at a failure face proposed its points at the
      // falling contour one after another (Hartmann-6, held-out ball 5, seed 26: P 0.75 → 0.61 over six trials,
      // 13 of 14 failed). Each failure of the refinement halves the probability of failure it accepts instead.
      refine_failures = std::count_if(failed_trials_.begin(), failed_trials_.end(),
                                      [&](Index t) { return t >= refine_trial_ && t < k; });
      p_min = 1.0 - (1.0 - p_min) * std::ldexp(1.0, -static_cast<int>(std::min<std::ptrdiff_t>(refine_failures, 60)));
    }
  }
  if (weighted)
    feasible = std::make_unique<FeasibilityWeightedAcquisition>(
        base, *feasibility_, failure_utility(base, data_.X), p_min, !refining_ || refine_weighted_);
  if (feasible && space_) feasible->set_evaluated_point([this](const Vec& x) { return evaluated_point(x); });
  if (feasible && !refining_ && !blocked_.empty() && failure_settings_.boundary_tabu > 0)
    feasible->set_tabu(blocked_, failure_settings_.boundary_tabu);
  const Acquisition& weighed = feasible ? static_cast<const Acquisition&>(*feasible) : base;
  // A surrogate without gradients (allowed: docs/plugins.md): the acquisitions read its empty gradients as zeros
  // and still said they had one, so gradient optimizers stopped where they started and the derivative-free
  // fallback never ran (a third-party surrogate: EI 0.196 found against 0.353, 7 repeated θ in 30 trials; red
  // team, session 30). Its acquisition is searched by values only then.
  const ValuesOnly values_only(weighed);
  if (!model_gradients && !said_no_gradients_) {
    said_no_gradients_ = true;
    log_info("bo: surrogate '{}' gives no gradients: the acquisition is optimized from its values only", surrogate_name_);
  }
  const Acquisition& acquisition = model_gradients ? weighed : values_only;
  AcquisitionFunction unscaled(acquisition, dim_);
  const double scale = acquisition_scale(*surrogate_);  // 1 unless the costs are tiny (acquisition_scale.hpp)
  const ScaledFunction f(unscaled, scale);
  Rng orng = rng_.stream(kOptimize, uk * 2);
  const Mat starts = starts_near(region_->seeds(), *region_, orng);
  OptimizeResult res = optimizer_->maximize(f, *region_, starts, orng);
  res.value /= scale;
  if (!res.success) {
    // No finite value at a feasible point: the x of such a result is arbitrary (sample_polish's is the box
    // centre, possibly outside the region). The best feasible start instead (issue 12, item 10).
    const std::optional<Vec> start = best_feasible(f, starts);
    log_warn("bo: trial {}: the acquisition optimizer failed ({}); {}", k, res.message,
             start ? "suggesting the best feasible start instead" : "no feasible start either");
    if (start) res.x = *start;
    else res.x = Vec();  // chosen at random below
  }
  // A refinement point already measured, of a deterministic cost: the attempts' acquisition's best new point instead.
  if (refining_ && feasible && res.x.size() == dim_ && res.x.allFinite())
    if (const std::optional<Vec> fresh = refine_past_known(k, *phase.acquisition, actx, p_min, model_gradients, starts,
                                                           res.x, model_data->y))
      res.x = *fresh;
  // With the failure model off (`failure_model: {enabled: off}`) a failed θ is not in the data, and the acquisition's
  // best point stayed where it was: 24 of 30 trials fell at one θ (red team, session 30). A failed θ is then kept
  // out as a pending one is.
  const bool avoid_failed = !feasibility_on_ && !failed_.empty();
  const double exclusion =
      std::max(pending_distance_ > 0 ? pending_distance_ : 1e-6, pending_distance_ > 0 ? integer_exclusion_ : 0.0);
  if (res.x.size() == dim_ && res.x.allFinite() &&
      ((pending_distance_ > 0 && data.size() > data_.size()) || avoid_failed)) {
    // The rows of `data` past the real observations are fantasies: points pending elsewhere and earlier points of
    // this batch. Their θ is not handed out a second time (pending_exclusion.hpp).
    std::vector<Vec> pending;
    if (pending_distance_ > 0)
      for (Index i = data_.size(); i < data.size(); ++i) pending.push_back(data.X.row(i).transpose());
    if (avoid_failed) pending.insert(pending.end(), failed_.begin(), failed_.end());
    const Index hit = nearest_within(Box::unit(dim_).clamp(res.x), pending, exclusion);
    if (hit >= 0) {
      const AwayFromPoints away(acquisition, pending, exclusion, AwayFromPoints::below_values(acquisition, data.X));
      AcquisitionFunction g_unscaled(away, dim_);
      const ScaledFunction g(g_unscaled, scale);
      Rng prng = rng_.stream(kPendingAway, uk);
      OptimizeResult again = optimizer_->maximize(g, *region_, starts, prng);
      again.value /= scale;
      const bool clear = again.success && again.x.size() == dim_ && again.x.allFinite() &&
                         nearest_within(Box::unit(dim_).clamp(again.x), pending, exclusion) < 0;
      log_info("bo: trial {}: the acquisition's best point is a pending {}; {}", k,
               avoid_failed ? "or failed one" : fmt::format("one (pending point {} of {})", hit + 1, pending.size()),
               clear ? fmt::format("searched again at least {:g} away from them", exclusion)
                     : std::string("no other point found: choosing at random"));
      if (clear) res = again;
      else res.x = Vec();  // chosen at random below
    }
  }
  s.acquisition_seconds = seconds_since(t_acq);
  if (res.x.size() != dim_ || !res.x.allFinite()) {
    // Say what was wrong and whose result it was (a third-party optimizer's empty, wrong-length or NaN x read
    // "found no point at trial 4 ()"; red team, session 23).
    const std::string what = res.x.size() == 0 ? std::string("no point")
                             : res.x.size() != dim_ ? fmt::format("a point of dimension {}, expected {}", res.x.size(), dim_)
                                                    : std::string("a point with a non-finite coordinate");
    log_warn("bo: acquisition optimization found no point at trial {} ({}: {}{}); choosing at random", k,
             optimizer_name_, what, res.message.empty() ? "" : "; " + res.message);
    s.x = random_point_avoiding_failures(orng);
    s.phase = "random";
    return s;
  }
  if (feasible && feasible->in_tabu(Box::unit(dim_).clamp(res.x))) {
    // Every start ended next to a blocked attempt's best point (boundary_restart): a random point instead.
    log_debug("bo: trial {}: the acquisition's best point lies next to a blocked attempt's best; choosing at random", k);
    s.x = random_point_avoiding_failures(orng);
    s.phase = "random";
    return s;
  }
  if (feasible && feasibility_->probability(evaluated_point(res.x)) < p_min) {
    // Every start ended where failure is likely (judged at the point that would be evaluated: with typed
    // parameters its rounding): never suggest it; a random point where success is likely.
    // The level applied is named with its value: "< min_probability" was printed where the incumbent's level
    // (refine_min_probability, 0.8) applied and min_probability was 0.5 (red team, session 24).
    if (refining_ && refine_failures > 0) {
      // No point of the refinement's box is as likely to succeed as refine_backoff asks. On a deterministic cost,
      // the refinement's best new point of the whole box at that level (backoff_fallback: new, session 45);
      // else the incumbent, a known success, is measured again. A random point of the whole box instead failed 19
      // of 31 times (held-out ball 5 of Hartmann-6, 80 seeds, session 42), and in the last trials of a run it could
      // not be followed up anyway.
      s.phase = "refine";
      if (const std::optional<Vec> fresh =
              backoff_new_point(k, *refine_acquisition_, actx, p_min, model_gradients, model_data->y)) {
        s.x = *fresh;
        return s;
      }
      Index best = 0;
      data_.y.minCoeff(&best);
      log_info("bo: trial {}: the refinement's best point has P(success) {:.3g} < {:.3g} (the incumbent's level, the "
               "probability of failure halved for each of the refinement's {} failed trials: refine_backoff); the "
               "incumbent is measured again", k, feasibility_->probability(evaluated_point(res.x)), p_min,
               refine_failures);
      s.x = data_.X.row(best).transpose();
      s.phase = "refine";
      return s;
    }
    // The rule that set the level, named: after failures in a row streak_backoff raises it above
    // refine_min_probability, and the message named that cap beside a level of 0.999 (audit, session 48).
    log_warn("bo: trial {}: the acquisition's best point has P(success) {:.3g} < {:.3g} ({}); choosing at random", k,
             feasibility_->probability(evaluated_point(res.x)), p_min,
             failure_streak > 0 && p_min > exclusion_threshold_
                 ? fmt::format("the incumbent's level, at most refine_min_probability, with the probability of failure "
                               "halved for each of the {} failed trials in a row: streak_backoff",
                               failure_streak)
             : p_min > exclusion_threshold_ ? std::string("the incumbent's level, at most refine_min_probability")
                                            : std::string("min_probability"));
    s.x = random_point_avoiding_failures(orng);
    s.phase = "random";
    return s;
  }
  // A point outside the box is the optimizer's bug (the built-in ones keep to it): clamped as before, but said,
  // naming it (a third-party optimizer's stray points were clamped silently; session 23's note).
  if (!Box::unit(dim_).contains(res.x, 1e-9))
    log_warn("bo: trial {}: acquisition optimizer '{}' returned a point outside the unit cube (max |coordinate - "
             "clamp| {:.3g}); clamped into it",
             k, optimizer_name_, (res.x - Box::unit(dim_).clamp(res.x)).cwiseAbs().maxCoeff());
  s.x = Box::unit(dim_).clamp(res.x);
  // A region's constraint (a safety set) binds the optimizer only through their capability tags: a third party's
  // region without its `needs: optimizer:constraints` tag, paired with an optimizer that ignores constraints, had 8
  // of 18 suggestions outside its ellipsoid in silence (red team, session 31). Said, once per process.
  if (region_->has_constraint() && region_->constraint(s.x, nullptr) < -1e-4)
    log_warn_once(fmt::format("bo: acquisition optimizer '{}' returned a point outside region '{}''s constraint "
                              "(first at trial {}, constraint value {:.3g} < 0): the pair does not keep to it; does the "
                              "region declare `needs: optimizer:constraints` (docs/plugins.md)?",
                              optimizer_name_, region_name_, k, region_->constraint(s.x, nullptr)));
  s.phase = refining_ ? "refine" : phase.name;
  // The attempt ends here (why: the log's reason); the region restarts afresh with a new design.
  const auto restart_afresh = [&](const char* why) {
    begin_fresh_attempt(k, fresh_region->fresh_starts(), data);
    log_info("bo: trial {}: {}; the region restarts afresh ({}): a new design of {} points", k, why, fresh_starts_,
             restart_points_);
    s.x = fresh_design_point(k, refit);
    s.phase = probe_trial_ == k ? "probe" : "restart";
    return s;
  };
  const bool may_restart = fresh_region && !refining_ && !final_stretch && restart_points_ > 0;
  if (may_restart && failure_settings_.failure_run > 0 && !failed_.empty() && feasibility_on_ &&
      data.size() > fresh_from_) {
    // failure_model.failure_run (session 37; docs/failures.md, item 9). Held-out regions of Hartmann-6: where a
    // failure boundary passes through the incumbent, the incumbent's level of P(success) fell with the incumbent's
    // own P as failures gathered beside it, the trust region does not shrink on failed trials, and 10 trials in a
    // row failed (P(success) 0.5–0.65 each) until stop_after_failures ended the run (region 3 seed 70, region 5
    // seed 59). On a robot, each is a fall. Not 3: attempts still approaching a minimiser beside a failure face
    // fail 3–5 times in a row while the classifier learns the face, and cutting them lost the basin.
    const Index run = failed_in_a_row(k);
    const Index stuck = attempt_best(data);
    if (run >= failure_settings_.failure_run && restart_on_known(data, stuck, region_rule, region_rng)) {
      remember_if_blocked(k, data);  // later attempts keep off it if a failure blocks its descent (blocked_tabu)
      return restart_afresh(fmt::format("the attempt's last {} trials failed", run).c_str());
    }
  }
  if (may_restart && converged_on_repeat(k, s.x, data, *model_data, region_rule, region_rng))
    return restart_afresh("the attempt proposed a point it has evaluated: converged");
  if (may_restart && feasible && blocked_at_boundary(k, s.x, data, p_min)) {
    const Index blocked = attempt_best(data);
    if (restart_on_known(data, blocked, region_rule, region_rng)) {
      blocked_.push_back(data.X.row(blocked).transpose());
      return restart_afresh("the attempt's best point is blocked by the failure boundary");
    }
  }
  if (may_restart && feasible && failure_settings_.boundary_jump != "off" && feasibility_on_ && !failed_.empty() &&
      failure_settings_.active(static_cast<Index>(failed_.size()))) {
    // failure_model.boundary_jump (session fail14): an attempt whose best point is blocked by an observed failure
    // ahead along the cost model's descent probes, once per blocked point, the far side of the failure zone along
    // that descent: the first point past the zone where P(success) is back above the exclusion threshold (far), or
    // (edge) also, where the ray leaves the box first with P(success) rising again, the last point in the box.
    const Index b = attempt_best(data);
    const Vec bx = data.X.row(b).transpose();
    bool done = false;
    for (const Vec& j : jumped_) done = done || (j - bx).lpNorm<Eigen::Infinity>() <= failure_settings_.boundary_reach;
    if (!done)
      if (const auto blocked = blocked_direction(k, s.x, data, p_min)) {
        const Vec& dir = blocked->first;  // ∞-norm 1: a step t moves the largest coordinate by t
        jumped_.push_back(bx);
        bool dipped = false;
        double lowest = 1, t_end = 0, p_last = 0;
        Vec last;
        for (double t = blocked->second / dir.norm() * 0.8; t <= 2.0; t += 0.01) {
          const Vec z = bx + t * dir;
          t_end = t;
          if ((z.array() < 0.0).any() || (z.array() > 1.0).any()) {
            // Left the box: no far side, unless (edge) P(success) was rising again at the box's face.
            if (failure_settings_.boundary_jump == "edge" && dipped && last.size() == dim_ && p_last > lowest) {
              log_debug("bo: trial {}: blocked at trial point {}; probing the box's face past the failure zone at "
                        "distance {:.3g} (P(success) {:.3g}, lowest {:.3g})", k, b, t - 0.01, p_last, lowest);
              s.x = last;
              s.phase = "jump";
              return s;
            }
            break;
          }
          const double p = feasibility_->probability(z);
          lowest = std::min(lowest, p);
          last = z;
          p_last = p;
          if (p < exclusion_threshold_) dipped = true;
          else if (dipped) {
            log_debug("bo: trial {}: blocked at trial point {}; probing the far side of the failure zone at distance "
                      "{:.3g} (P(success) {:.3g})", k, b, t, p);
            s.x = z;
            s.phase = "jump";
            return s;
          }
        }
        log_debug("bo: trial {}: blocked at trial point {}, no far side along the descent ({}): lowest P(success) "
                  "{:.3g} (threshold {:.3g}), the ray left the box at {:.3g}", k, b, fmt::join(dir, ", "), lowest,
                  exclusion_threshold_, t_end);
      }
  }
  if (may_restart && feasible)
    if (std::optional<Vec> probe = attempt_probe(k, data, refit)) {
      s.x = *probe;
      s.phase = "probe";
      return s;
    }
  if (feasible && !refining_ && failure_settings_.feasible_region != "off" &&
      feasibility_->probability(s.x) <= p_min + failure_settings_.feasible_margin) {
    // failure_model.feasible_region: limited: the step was held back by the failure model, not by the cost model.
    limited_trials_.push_back(k);
    log_debug("bo: trial {}: the step is limited by P(success) ({:.3g}, level {:.3g})", k,
              feasibility_->probability(s.x), p_min);
  }
  if (feasible)
    log_debug("bo: trial {} acquisition {:.6g} {} | P(success) here {:.3g}", k, res.value, acquisition.state(),
              feasibility_->probability(s.x));
  else
    log_debug("bo: trial {} acquisition {:.6g} {}", k, res.value, acquisition.state());
  return s;
}
std::vector<Suggestion> BayesianOptimization::ask(Index q) {
  std::vector<Suggestion> out;
  // Batches: later points of a batch see the earlier ones as observed at a lie (batch_strategy: kriging
  // believer = their posterior mean, or a constant liar), with the hyperparameters of the first fit. Points
  // pending elsewhere (set_pending) are fantasies too, and they take their trial indices: a pending point of
  // the initial design is not handed out twice.
  const Index offset = static_cast<Index>(pending_.size());
  Dataset fantasy = data_;
  double prefit_seconds = 0;
  prefitted_ = false;
  if (offset > 0) {
    const Index k0 = told_ + offset;
    if (k0 >= design_.rows() && !phase_at(k0).random && data_.size() >= 2) {
      // Fit on the real observations only (of the current attempt or refinement, as suggest() would); the pending
      // points then enter at their lies.
      const auto t0 = std::chrono::steady_clock::now();
      fit_model(k0, model_data_of(data_));
      prefitted_ = true;
      prefit_seconds = seconds_since(t0);
    }
    for (const Vec& p : pending_) fantasy.add(p, lie(p));
  }
  // The initial design is handed out by what is still missing, not by position: a design point evaluated or
  // pending is matched to its row, and the next trial of the design takes the first row without one. In trial
  // order that is row k, as before; with a trial abandoned out of order (trial 0 abandoned, trial 1 done) the
  // position had pointed at trial 1's row again, a repeated experiment (red team, session 23), and now the
  // abandoned trial's point comes back.
  std::vector<bool> design_taken;
  if (told_ + offset < design_.rows()) design_taken = design_rows_taken();
  for (Index j = 0; j < q; ++j) {
    Suggestion s = suggest(told_ + offset + j, fantasy, j == 0);
    if (told_ + offset + j < design_.rows()) {
      const auto free = std::find(design_taken.begin(), design_taken.end(), false);
      if (free != design_taken.end()) {
        *free = true;
        s.x = design_point(static_cast<Index>(free - design_taken.begin()));
      }
    }
    // The acquisition was maximized over the relaxation (piecewise constant in the integer and categorical
    // coordinates); what is evaluated, and what later points of the batch see, is its admissible point.
    if (space_) s.x = space_->admissible(s.x);
    if (j == 0) s.fit_seconds += prefit_seconds;
    if (j + 1 < q) {
      const double believed = batch_strategy_ == BatchStrategy::KrigingBeliever
                                  ? (model_ready_ ? surrogate_->predict(s.x, false).mean
                                                  : (fantasy.size() ? fantasy.y.mean() : 0.0))
                                  : lie(s.x);
      fantasy.add(s.x, believed);
    }
    out.push_back(std::move(s));
  }
  prefitted_ = false;
  return out;
}

Vec BayesianOptimization::design_point(Index row) const {
  const Vec x = design_.row(row).transpose();
  return space_ ? space_->admissible(x) : x;
}

std::vector<bool> BayesianOptimization::design_rows_taken() const {
  std::vector<bool> taken(static_cast<std::size_t>(design_.rows()), false);
  std::vector<Vec> points;
  for (Index i = 0; i < data_.size(); ++i) points.push_back(data_.X.row(i).transpose());
  points.insert(points.end(), failed_.begin(), failed_.end());
  points.insert(points.end(), pending_.begin(), pending_.end());
  // Each point takes one row (the first free equal one): a replicated design row is two rows.
  std::vector<const Vec*> unmatched;
  for (const Vec& p : points) {
    bool matched = false;
    for (Index r = 0; r < design_.rows() && !matched; ++r) {
      if (taken[static_cast<std::size_t>(r)]) continue;
      const Vec x = design_point(r);
      if (x.size() == p.size() && (x - p).cwiseAbs().maxCoeff() <= 1e-12) taken[static_cast<std::size_t>(r)] = matched = true;
    }
    if (!matched && p.size() == dim_) unmatched.push_back(&p);
  }
  // A point told near a row rather than at it (the caller evaluated the design point rounded to its own grid,
  // e.g. an Optuna float with a step) takes the nearest free row when it lies closer to it than half the design's
  // smallest spacing: unambiguously that row's evaluation. Before, the row stayed free and was handed out again,
  // the same experiment five times over (red team, session 24).
  if (!unmatched.empty() && design_.rows() >= 2) {
    double spacing = std::numeric_limits<double>::infinity();
    for (Index a = 0; a < design_.rows(); ++a)
      for (Index b = a + 1; b < design_.rows(); ++b)
        spacing = std::min(spacing, (design_point(a) - design_point(b)).norm());
    for (const Vec* p : unmatched) {
      Index nearest = -1;
      double d_nearest = 0.5 * spacing;
      for (Index r = 0; r < design_.rows(); ++r) {
        if (taken[static_cast<std::size_t>(r)]) continue;
        const double d = (design_point(r) - *p).norm();
        if (d < d_nearest) nearest = r, d_nearest = d;
      }
      if (nearest >= 0) taken[static_cast<std::size_t>(nearest)] = true;
    }
  }
  return taken;
}

void BayesianOptimization::tell(const std::vector<Observation>& observations) {
  for (const Observation& o : observations) {
    const bool in_design = told_ < design_.rows();  // results arrive in trial order in a run
    ++told_;
    design_told_ += in_design;
    if (!o.ok || !std::isfinite(o.cost)) {
      design_failed_ += in_design;
      // Failed trials inform the failure model only (the cost model has no value for them).
      if (o.x.size() == dim_ && o.x.allFinite()) failed_.push_back(o.x);
      failed_trials_.push_back(told_ - 1);
      if (failure_settings_.enabled == FailureModelSettings::Enabled::Off)
        log_warn_once("bo: a trial failed with `failure_model: {enabled: off}`: failures teach the search nothing, "
                      "so it may keep returning to where trials fail (only the failed θ themselves are kept out); "
                      "`enabled: auto`, the default, steers away from them");
      continue;
    }
    if (o.x.size() != dim_) throw InputError(fmt::format("bo: observation of dimension {}, expected {}", o.x.size(), dim_));
    data_.add(o.x, o.cost);
  }
  // The rules that change once a trial has failed are functions of the trials told (a restored bo gets them back
  // through tell()): failure_model.short_restarts shortens a fresh start's design to d + 1 points, and
  // failure_model.refine_last lengthens the final refinement to at least 2(d + 1) trials.
  const bool failures_seen = !failed_trials_.empty() && failure_settings_.enabled != FailureModelSettings::Enabled::Off;
  restart_points_ = failures_seen && failure_settings_.short_restarts
                        ? std::min<Index>(configured_restart_points_, dim_ + 1)
                        : configured_restart_points_;
  const Index failure_refine = failure_settings_.refine_last >= 0 ? failure_settings_.refine_last : 2 * (dim_ + 1);
  refine_last_ = failures_seen ? std::max(configured_refine_last_, failure_refine) : configured_refine_last_;
}

std::optional<Vec> BayesianOptimization::recommendation() const {
  if (data_.size() == 0) return std::nullopt;
  // The final recommendation (budget spent) refits the hyperparameters on all data; before that the
  // recommendation model is only conditioned with the latest fitted ones (one O(N³) solve per trial).
  const bool final = budget_ > 0 && told_ >= budget_;
  Rng rrng = rng_.stream(kRecommend, static_cast<std::uint64_t>(told_));
  Mat failed(static_cast<Index>(failed_.size()), dim_);
  for (std::size_t i = 0; i < failed_.size(); ++i) failed.row(static_cast<Index>(i)) = failed_[i].transpose();
  // LowestMeanDomain with failed trials: the failure model's classifier fitted on every trial (the run's own was
  // fitted at the last ask, without the latest result), so the recommendation stays where success is likely.
  std::optional<FeasibilityModel> odds_model;
  SuccessOdds odds;
  if (recommender_->rule() == RecommendationRule::LowestMeanDomain && !failed_.empty() &&
      failure_settings_.active(static_cast<Index>(failed_.size()))) {
    odds_model.emplace(dim_);
    odds_model->set_ard(failure_settings_.lengthscales == "ard");
    odds_model->set_fit_failures(failure_settings_.fit_failures);
    if (fit_feasibility(*odds_model)) {
      const FeasibilityModel& f = *odds_model;
      odds.probability = [&f](const Vec& x, Vec* grad) { return f.probability(x, grad); };
      odds.cap = failure_settings_.refine_min_probability;
    }
  }
  return recommender_->recommend(model_ready_ ? surrogate_.get() : nullptr, data_, failed, *region_,
                                 *recommend_optimizer_, rrng, final, odds);
}

std::optional<ModelSnapshot> BayesianOptimization::snapshot() const {
  if (!model_ready_) return std::nullopt;
  return snapshot_;
}

}  // namespace varbo::bo

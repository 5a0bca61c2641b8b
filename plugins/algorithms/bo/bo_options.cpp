// The options of `bo` and of its phases: one declaration each drives validation, defaults and
// `varbo plugins --describe bo` (options.hpp).
#include <string>
#include <utility>
#include <vector>

#include "bayesian_optimization.hpp"
#include "varbo/option_set.hpp"

namespace varbo::bo {

// epsilon's -1 ("the algorithm's") is not a value of Phase::epsilon: declared here only.
const OptionSet<Phase>& phase_options() {
  static const OptionSet<Phase> set{
      opt::integer("evaluations", &Phase::evaluations, "trials in this phase (0 = until the budget is spent)")
          .at_least(0),
      opt::boolean("random", &Phase::random,
                   "choose points with the initial-design sampler instead of the acquisition"),
      opt::component("acquisition", Kind::Acquisition, "", "acquisition of this phase (default: the algorithm's)"),
      opt::real("epsilon", -1, "probability of a random point instead (default: the algorithm's epsilon)")
          .at_least(-1)
          .at_most(1),
  };
  return set;
}


namespace {
/// replicate_design has no declared default: when not given it follows the surrogate (its
/// tests_noise_on_replicates), and an unset option stays out of the resolved configuration, so a stored study
/// reopens with the design it ran (one stored before session 17 lists `replicate_design: false`).
BoundOption<BoSettings> replicate_design_option() {
  return BoundOption<BoSettings>(
             opt::boolean("replicate_design", false,
                          "the last point of the initial design and of each fresh start's design repeats its first "
                          "(an exact replicate: shows the surrogate whether the cost is noisy). When not given: true "
                          "if the surrogate tests its data for noise (a gp with noise_test_level, by default the gp "
                          "with kernel se_ard), false otherwise"),
             [](const Options& o, BoSettings& s) { s.replicate_design = o.boolean("replicate_design"); })
      .when_given();
}

/// pending_distance is also left out of the resolved configuration unless given, so studies stored before it
/// existed reopen with the identity they were created with.
BoundOption<BoSettings> pending_distance_option() {
  return BoundOption<BoSettings>(
             opt::real("pending_distance", BoSettings{}.pending_distance,
                       "a model-based suggestion within this distance (∞-norm, unit cube) of a point pending "
                       "elsewhere or earlier in the batch is searched again outside that neighbourhood, so two "
                       "workers do not run the same θ (0 = a pending θ may be suggested again, e.g. as a replicate "
                       "under noise); 1e-3 when not given")
                 .at_least(0)
                 .at_most(0.5),
             [](const Options& o, BoSettings& s) { s.pending_distance = o.real("pending_distance"); })
      .when_given();
}

std::vector<std::pair<std::string, RecommendationRule>> recommendation_mapping() {
  std::vector<std::pair<std::string, RecommendationRule>> out;
  for (const std::string& name : recommendation_rule_names()) out.emplace_back(name, recommendation_rule(name));
  return out;
}
}  // namespace

const OptionSet<BoSettings>& bo_options() {
  static const OptionSet<BoSettings> set{
      // Latin hypercube by default: a handful of digitally shifted Sobol points in d ≥ 5 lie on a few diagonal
      // lines (point 2 = point 1 + 0.25 in every coordinate); on Hartmann-6 with 10 points that design left 6 of 10
      // seeds in a local minimum against 2 of 10 with LHS (README, benchmarks).
      opt::component("initial_design", Kind::Sampler, "lhs", "sampler of the initial design and random points"),
      opt::integer("initial_points", &BoSettings::initial_points, "initial design size (-1 = 2·(d+1), capped by the budget; 0 = no design: "
                   "random points until 2 trials have succeeded, then the model)")
          .at_least(-1),
      opt::component("surrogate", Kind::Surrogate, "gp", "model of the cost"),
      opt::component("acquisition", Kind::Acquisition, "ei", "selection criterion (maximized)"),
      // TuRBO-1's trust region by default (Eriksson et al. 2019): EI in the whole box kept spending trials on the
      // corners of Ackley-5 (median regret 1.9 against 0.036, seeds 1–20) and matched it everywhere else
      // (docs/defaults.md).
      opt::component("region", Kind::Region, "trust_region", "where the acquisition may search"),
      opt::component("acquisition_optimizer", Kind::Optimizer, "multistart", "maximizer of the acquisition"),
      opt::integer("refine_last", &BoSettings::refine_last,
                   "when the region restarts afresh (trust_region with restart_center: new_points), the last "
                   "trials of the budget start no new attempt and refine the incumbent of all the data (-1 = d + 1; once a "
                   "trial has failed, at least failure_model.refine_last)")
          .at_least(-1),
      opt::boolean("refine_early", &BoSettings::refine_early,
                   "when fewer trials remain than a fresh start's design and the current attempt holds the incumbent "
                   "of all the data, the final refinement begins at once (else in the last refine_last trials)"),
      replicate_design_option(),
      opt::integer("restart_points", &BoSettings::restart_points,
                   "design size of each fresh start of the region (-1 = initial_points; at most initial_points; 0 = "
                   "a fresh start draws no design: the model's search goes on in the new region)")
          .at_least(-1),
      opt::choice("restart_design", &BoSettings::restart_design, {"lhs", "away"},
                  "a fresh start's design: a new Latin hypercube (lhs), or the one of 16 whose nearest point to the "
                  "best point of every earlier attempt is farthest (away)"),
      opt::component("refine_acquisition", Kind::Acquisition, "{type: cb, kappa: 0}",
                     "acquisition of the final refinement after fresh starts (refine_last); the default minimizes "
                     "the posterior mean"),
      opt::choice("refine_model", &BoSettings::refine_model, {"all", "attempt", "basin", "local"},
                  "the model of the final refinement after fresh starts: all the data (all), the points of the "
                  "attempt that found the incumbent and the refinement's own (attempt), or those plus every other "
                  "point within 0.1 (∞-norm, unit cube) of the incumbent (basin), or only the points within 0.1 of the "
                  "incumbent once there are 2·(d + 1), else as basin (local)"),
      opt::choice("refine_feasibility", &BoSettings::refine_feasibility, {"exclude", "weight"},
                  "with failed trials, the final refinement (refine_last) only excludes θ where failure is likely "
                  "(exclude), or weights its acquisition by P(success) like the other trials (weight)"),
      opt::integer("refit_every", &BoSettings::refit_every,
                   "optimize hyperparameters every k model iterations (else only condition)")
          .at_least(1),
      opt::real("epsilon", &BoSettings::epsilon,
                "probability of a random point instead of the acquisition's choice (ε-random)")
          .at_least(0)
          .at_most(1),
      opt::choice("batch_strategy", &BoSettings::batch_strategy,
                  {{"kriging_believer", BatchStrategy::KrigingBeliever},
                   {"constant_liar_min", BatchStrategy::ConstantLiarMin},
                   {"constant_liar_mean", BatchStrategy::ConstantLiarMean}},
                  "how points of a batch and points pending elsewhere enter the model before they are observed "
                  "(Ginsbourger 2010): at the posterior mean, or at the min / mean of the observed costs"),
      pending_distance_option(),
      opt::choice("recommendation", &BoSettings::recommendation, recommendation_mapping(),
                  "the θ to deploy, chosen on a model conditioned on all observations (refitted once the budget "
                  "is spent): the evaluated θ with the lowest posterior mean; the posterior mean's minimum over "
                  "the search region; the evaluated θ with the lowest E + κ·s (κ = recommendation_kappa, "
                  "risk-averse for κ > 0); or the lowest observed cost"),
      opt::real("recommendation_kappa", &BoSettings::recommendation_kappa,
                "κ of the lowest_bound_evaluated recommendation rule"),
      // Unset unless given (read by hand below), so that the resolved configuration, and with it the identity of
      // every study stored before typed parameters existed, is unchanged.
      opt::choice("discrete", "", {"transform", "relax"},
                  "integer and categorical parameters: transform (the default) = the surrogate sees them rounded, "
                  "constant between admissible values (Garrido-Merchán & Hernández-Lobato 2020); relax = a continuous "
                  "model, rounded only at evaluation (a baseline)"),
      opt::node("phases", "",
                "list of phases after the initial design, e.g. [{evaluations: 15, random: true}, "
                "{evaluations: 15, acquisition: {type: ei, xi: 1}, epsilon: 0.2}, {acquisition: {type: cb, "
                "randomize: true}}]; the last phase continues until the budget is spent"),
      opt::node("failure_model", failure_model_default_yaml(),
                "failed trials (a map; keys left out keep these defaults): enabled: auto = on from the first "
                "failure; the acquisition is weighted by P(success | θ) from a GP classifier of successes and "
                "failures and θ with P < min_probability are never suggested; once a trial has failed, an attempt "
                "converged in value (stall_*) hands over to a fresh start sooner, a fresh design's likely failures "
                "move to the nearest likely success (design_repair), attempts that ended blocked by the failure "
                "boundary are kept off (blocked_tabu), a fresh start first probes where a model of every trial is "
                "confident of a gain (global_probe) and so does every (d + 1)-th trial of an attempt where that point lies in "
                "another basin (probe_every), six failures in a row end an attempt (failure_run), fresh designs "
                "have d + 1 points (short_restarts) and the final refinement at least 2(d + 1) trials (refine_last), "
                "which halves the failure probability it accepts after each of its failures (refine_backoff) and "
                "waits for a last attempt about to pass the incumbent (refine_waits) and does not measure a known θ "
                "of a deterministic cost again (refine_known), not even where its backoff leaves no point of "
                "its box (backoff_fallback), and the trust region's side "
                "stays at most 0.8 (length_max); the other keys are measured "
                "variants, off by default (docs/failures.md)"),
  };
  return set;
}

std::vector<OptionSpec> options() { return bo_options().specs(); }

}  // namespace varbo::bo

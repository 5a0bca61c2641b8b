// Failure-aware BO on Branin, Hartmann-6 and Hartmann-3 with a hidden failure region of about 30 % of the domain
// next to the global optimum (docs/failures.md): failure rate after the initial design and the regret of the recommended and
// of the best observed point, against the same runs without the failure region. Plain defaults ({type: bo}).
//
//   nice -n 10 build/bin/bench_failures [--seeds 10] [--first-seed 1] [--threads 2] [--set main|wider]
//                                       [--only KEY] [--budget N] [--algorithm '{type: bo, ...}'] [--with-failures-only]
//
// --set wider runs thirteen other regions beside the minimisers of Branin and Hartmann-6 instead of the main three
// (KEYs: branin, hartmann6, hartmann3; the wider set's are listed in kWider). The failure-free run of a task and seed
// is run once and shared by its regions.
//
// --budget N replaces every problem's budget (Branin 60, Hartmann-6 100, Hartmann-3 50).
// --task YAML --region YAML runs one problem of your own instead of a set (session 37: regions drawn at random, not
// tuned on): e.g. --task 'type: hartmann6' --region '{shape: ball, center: [...], radius: 0.6}' --budget 100; a run is
// stuck at regret >= --stuck (default 0.1 for hartmann6, else 0.01).
// --with-failures-only skips the failure-free runs (their columns read nan): for comparing variants of the
// failure handling, which cannot change a run in which no trial fails.
//
// A run that `stop_after_failures` ends (its default, 10 failed trials in a row) counts as stuck with regret inf and is
// listed in a note below the table.
//
// Prints a Markdown table (README and docs/failures.md) and each region's measured volume fraction, then (with the
// failure-free runs) a second table that splits the seeds by whether the region hides the failure-free run's best
// design point, where the failing run has lost the observation that led that run to its basin.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <string>
#include <unistd.h>
#include <vector>

#include "bo_table_config.hpp"
#include "varbo/csv.hpp"
#include "varbo/loader.hpp"
#include "varbo/log.hpp"
#include "varbo/math.hpp"
#include "varbo/study.hpp"

using namespace varbo;
using varbo::bench::quantile;

namespace {

struct Problem {
  std::string key, name, task, failure_region;
  int budget;
  double stuck;  ///< a run is "stuck" with a regret of at least this (outside the global basin)
};

// Branin: a disc of radius 0.31 (box fractions) at the centre of the square, area π·0.31² = 0.302; the global
// minimiser (π, 2.275) = (0.543, 0.152) lies 0.041 outside its edge, the other two far from it.
// Hartmann-6: the slab x6 > 0.7, volume 0.300 exactly; the minimiser has x6 = 0.657, 0.043 from its face.
const std::vector<Problem> kProblems = {
    {"branin", "Branin", "type: branin", "{shape: ball, center: [0.5, 0.5], radius: 0.31}", 60, 0.01},
    {"hartmann6", "Hartmann-6", "type: hartmann6", "{shape: box, lower: [0, 0, 0, 0, 0, 0.7], upper: [1, 1, 1, 1, 1, 1]}",
     100, 0.1},
    // Hartmann-3 (fail12): another dimension, budget and shape: the ball of radius 0.415 at (0.45, 0.55, 0.55),
    // inside the cube, volume 4/3·π·0.415³ = 0.299; the minimiser (0.115, 0.556, 0.853) lies 0.037 outside its
    // edge, the local minimum (0.109, 0.861, 0.565; −3.09) 0.047 outside, so the ball separates the two basins.
    {"hartmann3", "Hartmann-3", "type: hartmann3", "{shape: ball, center: [0.45, 0.55, 0.55], radius: 0.415}", 50,
     0.01},
};

// `--set wider` (session 32): other regions of 27–30 % of the box beside a global minimiser (0.04–0.08 from it, or
// covering one or two of Branin's three), to see whether the targets hold beyond the three regions above. Branin's
// minimisers in box fractions: TL (0.124, 0.818), BM (0.543, 0.152), BR (0.962, 0.165); Hartmann-6's (0.202, 0.150,
// 0.477, 0.275, 0.312, 0.657). Distances to the region, by a helper's Monte Carlo and geometry (docs/failures.md).
const std::vector<Problem> kWider = {
    {"branin_slab_x2_above_bottom", "Branin, slab 0.19 < x2 < 0.49", "type: branin",
     "{shape: box, lower: [0, 0.19], upper: [1, 0.49]}", 60, 0.01},
    {"branin_slab_x2_low", "Branin, slab x2 < 0.3 (covers BM, BR)", "type: branin",
     "{shape: box, lower: [0, 0], upper: [1, 0.3]}", 60, 0.01},
    {"branin_box_covers_tl", "Branin, box covering TL", "type: branin",
     "{shape: box, lower: [0, 0.2], upper: [0.48, 0.83]}", 60, 0.01},
    {"branin_ball_covers_bottom2", "Branin, disc covering BM, BR", "type: branin",
     "{shape: ball, center: [0.75, 0.25], radius: 0.32}", 60, 0.01},
    {"branin_disc_left", "Branin, disc left of the centre", "type: branin",
     "{shape: ball, center: [0.33, 0.5], radius: 0.31}", 60, 0.01},
    {"branin_box_covers_bm", "Branin, box covering BM", "type: branin", "{shape: box, lower: [0.3, 0], upper: [0.9, 0.5]}",
     60, 0.01},
    {"hartmann6_slab_x1", "Hartmann-6, slab 0.25 < x1 < 0.55", "type: hartmann6",
     "{shape: box, lower: [0.25, 0, 0, 0, 0, 0], upper: [0.55, 1, 1, 1, 1, 1]}", 100, 0.1},
    {"hartmann6_slab_x5_low", "Hartmann-6, slab x5 < 0.27", "type: hartmann6",
     "{shape: box, lower: [0, 0, 0, 0, 0, 0], upper: [1, 1, 1, 1, 0.27, 1]}", 100, 0.1},
    {"hartmann6_slab_x3", "Hartmann-6, slab 0.52 < x3 < 0.82", "type: hartmann6",
     "{shape: box, lower: [0, 0, 0.52, 0, 0, 0], upper: [1, 1, 0.82, 1, 1, 1]}", 100, 0.1},
    {"hartmann6_ball_centre", "Hartmann-6, ball towards the centre", "type: hartmann6",
     "{shape: ball, center: [0.561, 0.571, 0.505, 0.546, 0.538, 0.468], radius: 0.634}", 100, 0.1},
    {"hartmann6_ball_x2x4", "Hartmann-6, ball offset along x2, x4", "type: hartmann6",
     "{shape: ball, center: [0.202, 0.733, 0.477, 0.858, 0.312, 0.657], radius: 0.774}", 100, 0.1},
    {"hartmann6_slab_x2", "Hartmann-6, slab 0.195 < x2 < 0.495 (basin side)", "type: hartmann6",
     "{shape: box, lower: [0, 0.195, 0, 0, 0, 0], upper: [1, 0.495, 1, 1, 1, 1]}", 100, 0.1},
    {"hartmann6_box_x1x2", "Hartmann-6, box x1 < 0.6, 0.2 < x2 < 0.7 (basin side)", "type: hartmann6",
     "{shape: box, lower: [0, 0.2, 0, 0, 0, 0], upper: [0.6, 0.7, 1, 1, 1, 1]}", 100, 0.1},
};

struct Result {
  double regret_recommended = NAN, regret_best = NAN;
  int failed_after_design = 0, after_design = 0, failed = 0;
  bool stopped = false;  ///< `stop_after_failures` ended the run before its budget
  std::vector<double> design_cost;  ///< the initial design's costs in trial order, NaN where the trial failed
};

/// Whether the failure region hides the failure-free run's best design point: the two runs share their initial
/// design (the failure model begins at the first failure), so trial i of the design is the same θ in both, and the
/// failing run has no cost where the failure-free one found its best start. On Hartmann-6 this decides which basin
/// the first attempt reaches (docs/failures.md, session 18).
bool best_design_point_hidden(const Result& with, const Result& without) {
  const auto& c = without.design_cost;
  if (c.empty() || c.size() != with.design_cost.size()) return false;
  const std::size_t best = static_cast<std::size_t>(std::min_element(c.begin(), c.end()) - c.begin());
  return std::isnan(with.design_cost[best]);
}

Result run(const Registry& reg, const std::string& task_yaml, const std::string& algorithm, int budget, int seed,
           int threads, const std::string& out) {
  RunOverrides ov;
  ov.progress = false;
  ov.output = out;
  ov.threads = threads;
  ov.overwrite = true;  // a benchmark rewrites its scratch folders
  const std::string yaml =
      fmt::format("task: {{{}}}\nbudget: {}\nseed: {}\nalgorithm: {}\n", task_yaml, budget, seed, algorithm);
  StudyConfig s = parse_study(ConfigNode::parse(yaml, "<bench>"), reg);
  Result r;
  try {
    const RunSummary summary = run_study(s, reg, ov);
    r.failed = static_cast<int>(summary.failed);
    if (summary.regret_best_observed) r.regret_best = *summary.regret_best_observed;
    if (summary.regret_recommended) r.regret_recommended = *summary.regret_recommended;
  } catch (const InputError& e) {
    // `stop_after_failures` (default 10 in a row) ended the run, as it would end a user's: what the user has then is
    // a stopped study, so the run counts as stuck (regret +inf) and is counted in the table's note. Before session
    // 36 this escaped and ended the benchmark (terminate).
    std::fprintf(stderr, "seed %d: %s\n", seed, e.what());
    r.stopped = true;
    r.regret_best = r.regret_recommended = INFINITY;
  }
  const auto rows = read_csv_cells(out + "/trials.csv");
  const auto col = [&](const std::string& n) {
    return static_cast<std::size_t>(std::find(rows[0].begin(), rows[0].end(), n) - rows[0].begin());
  };
  for (std::size_t i = 1; i < rows.size(); ++i) {
    const bool ok = rows[i][col("ok")] == "1";
    r.failed += r.stopped && !ok;
    if (rows[i][col("phase")] != "initial") {
      ++r.after_design;
      r.failed_after_design += !ok;
    } else {
      r.design_cost.push_back(ok ? std::stod(rows[i][col("cost")]) : NAN);
    }
  }
  return r;
}

/// Share of 200,000 uniform points of the box where the task fails (the region's volume fraction).
double measured_fraction(const Registry& reg, const std::string& task_yaml) {
  BuildContext ctx;
  auto task = reg.create<Task>("{" + task_yaml + "}", ctx);
  const Domain d = task->domain();
  Rng rng(12345);
  const int n = 200000;
  int failed = 0;
  for (int i = 0; i < n; ++i) {
    Rng trial = rng.stream(0);
    failed += !task->evaluate(from_unit(rng.uniform_vec(d.box.dim()), d.box), trial).ok;
  }
  return static_cast<double>(failed) / n;
}

std::string cell(std::vector<double> v) {
  return fmt::format("{:.2g} [{:.2g}, {:.2g}]", quantile(v, 0.5), quantile(v, 0.25), quantile(v, 0.75));
}

/// The ratio of the medians (with / without failures) and its 90 % interval by a paired bootstrap over the seeds
/// (2,000 resamples of the seeds with replacement, each seed's two runs kept together; Rng(1): the same numbers on
/// every run). With 80 seeds the median of a heavy-tailed regret moves by a factor of several from one set of
/// seeds to the next (the README's per-20-seeds ratios run from 0.5 to 2.9 on one region), so a ratio of 2.4 is not
/// by itself a miss of "within 2×" nor 1.5 a pass: the interval says which regions are clearly inside or outside.
std::string ratio_cell(const std::vector<double>& with, const std::vector<double>& without) {
  const double ratio = quantile(with, 0.5) / quantile(without, 0.5);
  if (with.size() != without.size() || with.empty() || !std::isfinite(ratio)) return fmt::format("{:.2g}", ratio);
  Rng rng(1);
  const auto n = static_cast<Index>(with.size());
  std::vector<double> ratios, a(with.size()), b(with.size());
  for (int r = 0; r < 2000; ++r) {
    for (Index i = 0; i < n; ++i) {
      const auto k = static_cast<std::size_t>(rng.index(n));
      a[static_cast<std::size_t>(i)] = with[k];
      b[static_cast<std::size_t>(i)] = without[k];
    }
    const double r_resampled = quantile(a, 0.5) / quantile(b, 0.5);
    if (!std::isnan(r_resampled)) ratios.push_back(r_resampled);  // 0/0 or inf/inf: no ratio (stopped runs are inf)
  }
  if (ratios.empty()) return fmt::format("{:.2g}", ratio);
  return fmt::format("{:.2g} [{:.2g}, {:.2g}]", ratio, quantile(ratios, 0.05), quantile(ratios, 0.95));
}

}  // namespace

int main(int argc, char** argv) {
  int seeds = 10, first_seed = 1, threads = 0, budget = 0;
  std::string only, algorithm = "{type: bo}", set = "main", task, region;
  double stuck = -1;
  bool with_only = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--seeds" && i + 1 < argc) seeds = std::atoi(argv[++i]);
    else if (a == "--threads" && i + 1 < argc) threads = std::atoi(argv[++i]);
    else if (a == "--first-seed" && i + 1 < argc) first_seed = std::atoi(argv[++i]);
    else if (a == "--budget" && i + 1 < argc) budget = std::atoi(argv[++i]);
    else if (a == "--only" && i + 1 < argc) only = argv[++i];
    else if (a == "--set" && i + 1 < argc) set = argv[++i];
    else if (a == "--algorithm" && i + 1 < argc) algorithm = argv[++i];
    else if (a == "--with-failures-only") with_only = true;
    else if (a == "--task" && i + 1 < argc) task = argv[++i];
    else if (a == "--region" && i + 1 < argc) region = argv[++i];
    else if (a == "--stuck" && i + 1 < argc) stuck = std::atof(argv[++i]);
    else {
      std::fprintf(stderr,
                   "usage: %s [--seeds N] [--first-seed S] [--threads N] [--budget N] [--set main|wider] "
                   "[--only KEY] [--algorithm YAML] [--with-failures-only] [--task YAML --region YAML [--stuck X]]\n",
                   argv[0]);
      return 2;
    }
  }
  if (task.empty() != region.empty()) {
    std::fprintf(stderr, "--task and --region go together\n");
    return 2;
  }
  if (!task.empty() && budget <= 0) {
    std::fprintf(stderr, "--task needs --budget\n");
    return 2;
  }
  if (set != "main" && set != "wider") {
    std::fprintf(stderr, "--set %s: expected main or wider\n", set.c_str());
    return 2;
  }
  set_log_level(LogLevel::Error);
  Registry& reg = default_registry();
  const std::string tmp = 
      (std::filesystem::temp_directory_path() / fmt::format("varbo_bench_failures_{}", getpid())).string();
  std::printf("algorithm: %s; seeds %d-%d; threads %d\n\n", algorithm.c_str(), first_seed, first_seed + seeds - 1,
              threads);
  std::vector<std::string> stopped;  // regions with runs that `stop_after_failures` ended: a note below the table
  std::vector<std::string> split;  // the second table: seeds split by whether the design's best point is hidden
  std::printf("| problem (budget) | failure region (measured volume) | failed after the design: median [q1, q3] (pooled) "
              "| regret of the recommended θ, with failures | without | ratio of medians [90 %% paired bootstrap] | best-observed regret, with "
              "| without | stuck with / without |\n|---|---|---|---|---|---|---|---|---|\n");
  std::map<std::string, Result> failure_free;  // by task, budget and seed: shared by the regions of a task
  std::vector<Problem> problems = set == "wider" ? kWider : kProblems;
  if (!task.empty()) {
    const bool h6 = task.find("hartmann6") != std::string::npos;
    problems = {{"custom", task, task, region, budget, stuck >= 0 ? stuck : h6 ? 0.1 : 0.01}};
  }
  for (Problem p : problems) {
    if (budget > 0) p.budget = budget;  // --budget: every problem's budget
    if (!only.empty() && only != p.key) continue;
    const std::string failing = p.task + ", failure_region: " + p.failure_region;
    std::vector<double> rate, rec_with, rec_without, best_with, best_without;
    std::vector<double> hidden_with, hidden_without, shown_with, shown_without;
    int failed_pooled = 0, after_pooled = 0, stuck_with = 0, stuck_without = 0, stopped_with = 0, stopped_without = 0;
    for (int seed = first_seed; seed < first_seed + seeds; ++seed) {
      const Result w = run(reg, failing, algorithm, p.budget, seed, threads, fmt::format("{}/{}_f_{}", tmp, p.key, seed));
      const std::string free_key = fmt::format("{} {} {}", p.task, p.budget, seed);
      if (!with_only && !failure_free.count(free_key))
        failure_free[free_key] = run(reg, p.task, algorithm, p.budget, seed, threads, fmt::format("{}/{}_o_{}", tmp, p.key, seed));
      const Result o = with_only ? Result{} : failure_free[free_key];
      stuck_with += w.regret_recommended >= p.stuck;
      stuck_without += o.regret_recommended >= p.stuck;
      stopped_with += w.stopped;
      stopped_without += o.stopped;
      rate.push_back(static_cast<double>(w.failed_after_design) / std::max(1, w.after_design));
      failed_pooled += w.failed_after_design;
      after_pooled += w.after_design;
      const bool hidden = best_design_point_hidden(w, o);
      (hidden ? hidden_with : shown_with).push_back(w.regret_recommended);
      (hidden ? hidden_without : shown_without).push_back(o.regret_recommended);
      rec_with.push_back(w.regret_recommended);
      rec_without.push_back(o.regret_recommended);
      best_with.push_back(w.regret_best);
      best_without.push_back(o.regret_best);
      std::fprintf(stderr, "%s seed %d: failed %d/%d after the design (%d in all); regret rec %.3g vs %.3g, best %.3g vs %.3g%s\n",
                   p.name.c_str(), seed, w.failed_after_design, w.after_design, w.failed, w.regret_recommended,
                   o.regret_recommended, w.regret_best, o.regret_best, hidden ? "; best design point hidden" : "");
    }
    std::printf("| %s (%d) | %s (%.3f) | %.1f %% [%.1f, %.1f] (%.1f %%) | %s | %s | %s | %s | %s | %d / %d |\n",
                p.name.c_str(),
                p.budget, p.failure_region.c_str(), measured_fraction(reg, failing), 100 * quantile(rate, 0.5),
                100 * quantile(rate, 0.25), 100 * quantile(rate, 0.75), 100.0 * failed_pooled / std::max(1, after_pooled),
                cell(rec_with).c_str(), cell(rec_without).c_str(), ratio_cell(rec_with, rec_without).c_str(),
                cell(best_with).c_str(), cell(best_without).c_str(), stuck_with, with_only ? 0 : stuck_without);
    if (stopped_with + stopped_without > 0)
      stopped.push_back(fmt::format("- {}: {} run(s) with failures and {} without stopped after `stop_after_failures` "
                                    "failed trials in a row (counted as stuck, regret inf)",
                                    p.name, stopped_with, stopped_without));
    if (!with_only) {
      const auto group = [](const std::vector<double>& a, const std::vector<double>& b) {
        if (a.empty()) return std::string("–");
        return fmt::format("{}: {} / {}", a.size(), cell(a), cell(b));
      };
      split.push_back(fmt::format("| {} ({}) | {} | {} |", p.name, p.budget, group(hidden_with, hidden_without),
                                  group(shown_with, shown_without)));
    }
    std::fflush(stdout);
  }
  if (!stopped.empty()) std::printf("\n");
  for (const std::string& line : stopped) std::printf("%s\n", line.c_str());
  if (!split.empty()) {
    // Where the failure-free run's best design point lies inside the failure region, the failing run has lost the
    // observation that would have led it to that basin: a gap there is information, not the handling of failures.
    std::printf("\n| problem (budget) | seeds whose failure-free best design point the region hides: n: regret with / "
                "without | the other seeds |\n|---|---|---|\n");
    for (const std::string& row : split) std::printf("%s\n", row.c_str());
  }
  return 0;
}

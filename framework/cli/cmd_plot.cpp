// `varbo plot RUN_DIR [-o out.svg]`: SVG pictures of a run's learned cost model (Kuindersma 2013, Fig. 2-3).
// 1-D tasks: data, mean and ±2 s bands of a GP and a VHGP fit, and the κ-selected policies (CB, eq. 20).
// 2-D tasks: heat maps of the learned mean and standard deviation with the data and selections overlaid.
#include <fmt/format.h>

#include <cstdio>
#include <filesystem>

#include "cli_parse.hpp"
#include "commands.hpp"
#include "output_guard.hpp"
#include "component_arg.hpp"
#include "slice_values.hpp"
#include "varbo/host_task.hpp"
#include "varbo/errors.hpp"
#include "varbo/loader.hpp"
#include "varbo/log.hpp"
#include "varbo/math.hpp"
#include "varbo/parallel.hpp"
#include "varbo/run_folder.hpp"
#include "varbo/select.hpp"
#include "varbo/svg_plot.hpp"

namespace varbo::cli {

namespace {

/// The failed trials in user units (rows). They have no cost, so no model sees them; drawn as marks of their own, a
/// region where the robot fell was blank, the model extrapolating over it unflagged (audit, session 48).
Mat failed_theta(const RunFolder& run) {
  Mat out(run.failed.rows(), run.failed.cols());
  for (Index r = 0; r < run.failed.rows(); ++r)
    out.row(r) = (run.space ? run.space->decode(run.failed.row(r).transpose())
                            : from_unit(run.failed.row(r).transpose(), run.domain.box)).transpose();
  return out;
}
constexpr const char* kFailedColour = "#d62728";
std::string failed_label(const RunFolder& run) {
  return fmt::format("failed trials ({}; θ only, no cost)", run.failed.rows());
}

struct PlotArgs {
  std::string run, output, gp = "gp", vhgp = "vhgp", surrogate, optimizer = "{type: multistart, candidates: 2000, polish: 8}";
  std::string slice;  ///< typed parameters: the parameter along which the model is cut
  std::vector<double> kappas;
  std::vector<std::string> kappa_text;  ///< --kappa as given (decimal_items)
  long long seed = 1;
  int threads = 0, grid = 0;
};

// κ colours: blue risk-averse, red risk-seeking, black neutral (Fig. 2(d) uses dotted verticals).
std::string kappa_color(double k) { return k > 0 ? "#1f5fbf" : (k < 0 ? "#c0392b" : "#222222"); }
std::string kappa_label(double k) {
  if (k == 0) return "CB κ = 0 (risk-neutral)";
  return fmt::format("CB κ = {:+g} ({})", k, k > 0 ? "risk-averse" : "risk-seeking");
}

struct Fitted {
  std::string name;
  std::unique_ptr<Surrogate> model;
};

Fitted fit(const RunFolder& run, const Registry& registry, const ResolvedComponent& spec, std::uint64_t seed) {
  Fitted f{spec.info->name, make_run_surrogate(run, spec, registry, seed, true)};
  fit_run_surrogate(*f.model, run, seed);
  return f;
}

// The run's own spec when it is of this type (its options), else the command-line one.
ResolvedComponent spec_for(const RunFolder& run, const Registry& registry, const std::string& text,
                           const std::string& flag, bool given) {
  const ResolvedComponent* own = run_surrogate_spec(run);
  ResolvedComponent spec = registry.resolve(Kind::Surrogate, component_arg(text, "surrogate", flag));
  if (!given && own != nullptr && own->info == spec.info) return *own;
  return spec;
}

std::vector<RiskSelection> selections(const Surrogate& model, const RunFolder& run, const Registry& registry,
                                      const PlotArgs& a) {
  BuildContext octx;
  octx.dim = run.domain.box.dim();
  octx.seed = static_cast<std::uint64_t>(a.seed);
  auto opt = registry.create<Optimizer>(
      registry.resolve(Kind::Optimizer, component_arg(a.optimizer, "acquisition_optimizer", "--optimizer")), octx);
  std::vector<RiskSelection> sel = select_policies(model, run.domain, a.kappas, *opt,
                                                   Rng(static_cast<std::uint64_t>(a.seed)).stream(0x5e1), run.data.X,
                                                   nullptr, run.failed);
  for (const auto& s : sel)
    if (!s.ok) log_warn("plot: no selection for kappa {}: {}", s.kappa, s.message);
  return sel;
}

svg::Figure plot_1d(const RunFolder& run, const Registry& registry, const PlotArgs& a, bool gp_given, bool vhgp_given) {
  const auto seed = static_cast<std::uint64_t>(a.seed);
  const Fitted gp = fit(run, registry, spec_for(run, registry, a.gp, "--gp", gp_given), seed);
  const Fitted vh = fit(run, registry, spec_for(run, registry, a.vhgp, "--vhgp", vhgp_given), seed);
  const int n = a.grid > 0 ? a.grid : 400;
  const double lo = run.domain.box.lower[0], hi = run.domain.box.upper[0];
  std::vector<double> xs(static_cast<std::size_t>(n));
  struct Curve {
    std::vector<double> mean, lo, hi;
  };
  auto curve = [&](const Surrogate& m) {
    Curve c;
    for (int i = 0; i < n; ++i) {
      const double u = static_cast<double>(i) / (n - 1);
      xs[static_cast<std::size_t>(i)] = lo + u * (hi - lo);
      const Prediction p = m.predict(Vec::Constant(1, u), false);
      const double s = p.total_std();  // s of the cost: latent and noise variance (section 2.2)
      c.mean.push_back(p.mean);
      c.lo.push_back(p.mean - 2 * s);
      c.hi.push_back(p.mean + 2 * s);
    }
    return c;
  };
  const Curve cg = curve(*gp.model), cv = curve(*vh.model);
  const std::vector<RiskSelection> sel = selections(*vh.model, run, registry, a);

  // y range: the data and both bands, padded.
  double ylo = run.cost.size() ? run.cost.minCoeff() : 0.0, yhi = run.cost.size() ? run.cost.maxCoeff() : 1.0;
  for (const Curve* c : {&cg, &cv})
    for (int i = 0; i < n; ++i) {
      ylo = std::min(ylo, c->lo[static_cast<std::size_t>(i)]);
      yhi = std::max(yhi, c->hi[static_cast<std::size_t>(i)]);
    }
  // The surrogates drawn, by name: `--gp kreg` was labelled "GP" (red team, session 30).
  auto label = [](const std::string& name) { return name == "gp" ? std::string("GP") : name == "vhgp" ? std::string("VHGP") : name; };
  const std::string A = label(gp.name), B = label(vh.name);
  svg::Figure fig(1000, 520, fmt::format("{}: {} trials ({} successful), {} vs {} fit", run.study.task.info->name,
                                        run.trials, run.data.size(), A, B));
  svg::Panel& p = fig.panel(80, 50, 560, 400, {lo, hi}, svg::padded(ylo, yhi, 0.04));
  p.labels(run.names[0], "cost", "");
  p.legend_place(svg::Panel::LegendPlace::Right);
  p.band(xs, cg.lo, cg.hi, "#8c8c8c", 0.25, A + " ±2 s");
  p.band(xs, cv.lo, cv.hi, "#e69f00", 0.30, B + " ±2 s");
  p.line(xs, cg.mean, "#555555", 1.8, "6 4", A + " mean");
  p.line(xs, cv.mean, "#b35900", 2.2, "", B + " mean");
  std::vector<double> dx(run.theta.col(0).data(), run.theta.col(0).data() + run.theta.rows());
  std::vector<double> dy(run.cost.data(), run.cost.data() + run.cost.size());
  p.markers(dx, dy, svg::Marker::Circle, "#0b3d91", 3.6, "data", "data (trials)");
  if (run.failed.rows() > 0) {  // at the foot of the picture: they have no cost
    const Mat f = failed_theta(run);
    p.markers(std::vector<double>(f.col(0).data(), f.col(0).data() + f.rows()),
              std::vector<double>(static_cast<std::size_t>(f.rows()), ylo), svg::Marker::Cross, kFailedColour, 5,
              "failed", failed_label(run));
  }
  for (const auto& s : sel) {
    if (!s.ok) continue;
    p.vline(s.theta[0], kappa_color(s.kappa), s.kappa == 0 ? "2 3" : "5 4", "");
    p.markers({s.theta[0]}, {s.mean}, svg::Marker::Diamond, kappa_color(s.kappa), 6.5, "selected",
              fmt::format("{}: θ = {:.3f}", kappa_label(s.kappa), s.theta[0]));
  }
  return fig;
}

svg::Figure plot_2d(const RunFolder& run, const Registry& registry, const PlotArgs& a) {
  const auto seed = static_cast<std::uint64_t>(a.seed);
  ResolvedComponent spec;
  if (!a.surrogate.empty()) {
    spec = registry.resolve(Kind::Surrogate, component_arg(a.surrogate, "surrogate", "--surrogate"));
  } else if (const ResolvedComponent* own = run_surrogate_spec(run)) {
    spec = *own;
  } else {
    spec = registry.resolve(Kind::Surrogate, component_arg(a.vhgp, "surrogate", "--vhgp"));
  }
  // An SVG cell per grid point: 400² made a 23 MB file, the allowed 2000² ~575 MB, beyond what a browser opens.
  if (a.grid > 200)
    throw InputError(fmt::format("--grid {}: at most 200 points per axis for a 2-D picture (one SVG cell each: 200² "
                                 "is ~6 MB)",
                                 a.grid));
  const Fitted m = fit(run, registry, spec, seed);
  const int n = a.grid > 0 ? a.grid : 40;
  const Box& box = run.domain.box;
  Mat mean(n, n), sd(n, n);
  // Cell centres of an n × n grid; row i along the second parameter, column j along the first.
  parallel_for(n, [&](Index i) {
    for (Index j = 0; j < n; ++j) {
      Vec u(2);
      u << (static_cast<double>(j) + 0.5) / n, (static_cast<double>(i) + 0.5) / n;
      const Prediction p = m.model->predict(u, false);
      mean(i, j) = p.mean;
      sd(i, j) = p.total_std();
    }
  });
  const std::vector<RiskSelection> sel = selections(*m.model, run, registry, a);
  svg::Figure fig(1240, 600, fmt::format("{}: learned cost model ({}, {} trials, {} successful)",
                                         run.study.task.info->name, m.name, run.trials, run.data.size()));
  std::vector<double> dx(run.theta.col(0).data(), run.theta.col(0).data() + run.theta.rows());
  std::vector<double> dy(run.theta.col(1).data(), run.theta.col(1).data() + run.theta.rows());
  const svg::Range xr{box.lower[0], box.upper[0]}, yr{box.lower[1], box.upper[1]};
  const char* titles[2] = {"mean E[J]", "standard deviation s"};
  const Mat* grids[2] = {&mean, &sd};
  for (int k = 0; k < 2; ++k) {
    svg::Panel& p = fig.panel(80 + 620.0 * k, 60, 400, 400, xr, yr);
    p.labels(run.names[0], run.names[1], titles[k]);
    p.legend_place(svg::Panel::LegendPlace::Below);
    p.heatmap(*grids[k], k == 0 ? "E[J]" : "s");
    p.markers(dx, dy, svg::Marker::Circle, "#ffffff", 3.4, "data", k == 0 ? "data (trials)" : "");
    if (run.failed.rows() > 0) {
      const Mat f = failed_theta(run);
      p.markers(std::vector<double>(f.col(0).data(), f.col(0).data() + f.rows()),
                std::vector<double>(f.col(1).data(), f.col(1).data() + f.rows()), svg::Marker::Cross, kFailedColour,
                5, "failed", k == 0 ? failed_label(run) : "");
    }
    for (const auto& s : sel)
      if (s.ok)
        p.markers({s.theta[0]}, {s.theta[1]}, s.kappa > 0 ? svg::Marker::Diamond : svg::Marker::Triangle,
                  kappa_color(s.kappa), 7, "selected",
                  k == 0 ? fmt::format("{}: [{:.2f}, {:.2f}]", kappa_label(s.kappa), s.theta[0], s.theta[1]) : "");
  }
  return fig;
}

/// Typed parameters (docs/search_space.md): the model's mean ± 2 s along one named parameter, the others held at
/// the best observed trial's values; the data projected on that parameter. A log parameter is drawn over
/// log10 of its value; a category at its index (labels in the legend).
svg::Figure plot_slice(const RunFolder& run, const Registry& registry, const PlotArgs& a) {
  const SearchSpace& space = *run.space;
  const auto pi = space.index_of(a.slice);
  if (!pi) {
    const std::string near = closest_match(a.slice, run.names);
    throw InputError(fmt::format("--slice: the run has no parameter '{}' (it has {}){}", a.slice, join(run.names),
                                 near.empty() ? "" : "; did you mean '" + near + "'?"));
  }
  const std::size_t i = *pi;
  const Parameter& par = space.parameters()[i];
  if (par.type == ParameterType::Fixed) throw InputError(fmt::format("--slice: '{}' is fixed", a.slice));
  if (run.data.size() < 2) throw InputError(fmt::format("{}: fewer than 2 successful trials", run.folder));
  const auto seed = static_cast<std::uint64_t>(a.seed);
  const ResolvedComponent* own = run_surrogate_spec(run);
  const ResolvedComponent spec =
      !a.surrogate.empty() ? registry.resolve(Kind::Surrogate, component_arg(a.surrogate, "surrogate", "--surrogate"))
      : own                ? *own
                           : registry.resolve(Kind::Surrogate, component_arg(a.gp, "surrogate", "--gp"));
  const Fitted m = fit(run, registry, spec, seed);
  Index best = 0;
  run.cost.minCoeff(&best);
  const Vec base = run.theta.row(best).transpose();
  const std::vector<double> values = slice_values(par, a.grid > 0 ? a.grid : 400);
  auto axis = [&](double v) { return par.log ? std::log10(v) : v; };
  std::vector<double> xs, mean, lo, hi;
  for (const double v : values) {
    Vec t = base;
    t[static_cast<Index>(i)] = v;
    const Prediction p = m.model->predict(space.encode(t), false);
    xs.push_back(axis(v));
    mean.push_back(p.mean);
    lo.push_back(p.mean - 2 * p.total_std());
    hi.push_back(p.mean + 2 * p.total_std());
  }
  std::vector<double> dx, dy(run.cost.data(), run.cost.data() + run.cost.size());
  for (Index r = 0; r < run.theta.rows(); ++r) dx.push_back(axis(run.theta(r, static_cast<Index>(i))));
  double ylo = std::min(*std::min_element(lo.begin(), lo.end()), run.cost.minCoeff());
  double yhi = std::max(*std::max_element(hi.begin(), hi.end()), run.cost.maxCoeff());
  const svg::Range xr = par.type == ParameterType::Categorical
                            ? svg::Range{-0.5, static_cast<double>(par.choices.size()) - 0.5}
                            : svg::Range{axis(par.low), axis(par.high)};
  svg::Figure fig(1000, 520, fmt::format("{}: {} along '{}', the others at the best trial ({} successful trials)",
                                         run.study.task.info->name, m.name, par.name, run.data.size()));
  svg::Panel& p = fig.panel(80, 50, 560, 400, xr, svg::padded(ylo, yhi, 0.04));
  p.labels(par.log ? "log10(" + par.name + ")" : par.name, "cost", "");
  p.legend_place(svg::Panel::LegendPlace::Right);
  if (par.type == ParameterType::Categorical) {
    p.markers(xs, mean, svg::Marker::Diamond, "#b35900", 6.5, "mean", "mean E");
    p.markers(xs, lo, svg::Marker::Cross, "#e69f00", 5, "band", "±2 s");
    p.markers(xs, hi, svg::Marker::Cross, "#e69f00", 5, "band", "");
    for (std::size_t j = 0; j < par.choices.size(); ++j)
      p.vline(static_cast<double>(j), "#dddddd", "2 3", fmt::format("{} = {}", j, par.choices[j]));
  } else {
    p.band(xs, lo, hi, "#e69f00", 0.30, "±2 s");
    p.line(xs, mean, "#b35900", 2.2, "", "mean E");
  }
  p.markers(dx, dy, svg::Marker::Circle, "#0b3d91", 3.6, "data", "successful trials, projected");
  if (run.failed.rows() > 0) {  // projected too, at the foot of the picture: they have no cost
    const Mat f = failed_theta(run);
    std::vector<double> fx;
    for (Index r = 0; r < f.rows(); ++r) fx.push_back(axis(f(r, static_cast<Index>(i))));
    p.markers(fx, std::vector<double>(fx.size(), ylo), svg::Marker::Cross, kFailedColour, 5, "failed",
              failed_label(run));
  }
  p.vline(axis(base[static_cast<Index>(i)]), "#222222", "5 4", fmt::format("best trial: {}", space.format_value(i, base[static_cast<Index>(i)])));
  return fig;
}

/// Writes the SVG and prints where, unless it went to standard output itself (`-o -`, `-o /dev/stdout`).
void save_plot(const svg::Figure& fig, const std::string& out) {
  refuse_to_write_over_a_study(out, "-o");
  refuse_to_write_over_a_run_file(out, "-o");
  const bool to_stdout = is_standard_output(out);
  write_output(out, fig.render(), "the SVG file");
  if (!to_stdout) std::printf("%s\n", out.c_str());
}

}  // namespace

Runner add_plot(CLI::App& app) {
  auto* cmd = app.add_subcommand("plot", "Draw a run's learned cost model as SVG (1-D: GP and VHGP fits; 2-D: heat maps)");
  auto a = std::make_shared<PlotArgs>();
  auto* gp_opt = cmd->add_option("--gp", a->gp, "1-D: the homoscedastic surrogate (inline YAML or file)");
  auto* vh_opt = cmd->add_option("--vhgp", a->vhgp, "1-D: the heteroscedastic surrogate (inline YAML or file)");
  cmd->add_option("run", a->run, "run folder written by `varbo run`")->required()->check(run_folder());
  cmd->add_option("-o,--output", a->output, "SVG file, or - for standard output (default: RUN_DIR/model.svg)");
  cmd->add_option("--kappa", a->kappa_text, "risk factors of the marked CB selections (default: -1.5, 0, 1.5)")
      ->type_name("DECIMAL[,DECIMAL...]");
  cmd->add_option("--surrogate", a->surrogate, "2-D and --slice: model to draw (default: the run's surrogate)");
  cmd->add_option("--optimizer", a->optimizer, "maximizer of -(E + kappa*s) for the selections");
  cmd->add_option("--grid", a->grid, "grid points per axis (default 400 in 1-D, 40 in 2-D; at most 200 in 2-D)")->check(integer_in(2, 2000));
  cmd->add_option("--seed", a->seed, "random seed of the fits and the optimizer")
      ->capture_default_str()
      ->check(integer_in(0, 9223372036854775807LL));
  cmd->add_option("--threads", a->threads, "worker threads (0 = all)")->check(integer_in(0, 2147483647));
  cmd->add_option("--slice", a->slice,
                  "draw the model along this parameter, the others at the best trial (any run; the only way for typed "
                  "parameters and for 3 or more)");
  return [a, gp_opt, vh_opt]() {
    ThreadLimit limit(a->threads);
    const bool pair_given = gp_opt->count() > 0 || vh_opt->count() > 0;
    // An option the drawing does not use is refused, not ignored: `--gp` on a 2-D run drew the run's own model and
    // the user took it for the one asked for.
    auto refuse_pair = [&](const std::string& why) {
      if (pair_given)
        throw InputError(fmt::format("{}: --gp and --vhgp name the two models of a 1-D plot; {}, name its model "
                                     "with --surrogate", a->run, why));
    };
    if (a->seed < 0) throw InputError("--seed: expected a non-negative integer");
    a->kappas = a->kappa_text.empty() ? std::vector<double>{-1.5, 0.0, 1.5}
                                      : decimal_items(a->kappa_text, "--kappa", "-1.5,0,1.5");
    Registry& registry = run_folder_registry(a->run);  // with the run's own plugins
    // A run of varbo.minimize has the task `python`: its domain is all an offline command needs (an evaluation, as
    // rescore's --rollouts, is a failed trial saying why). They refused such runs (red team, session 25).
    if (!registry.try_find(Kind::Task, "python")) add_host_python_task(registry);
    const RunFolder run = load_run_folder(a->run, registry);
    if (run.space) {  // typed parameters: a cut along one named parameter (its axes are not encoded coordinates)
      if (a->slice.empty())
        throw InputError(fmt::format("{}: the run has typed parameters or constraints; name the parameter to draw "
                                     "with --slice NAME (one of {})",
                                     a->run, join(run.names)));
      refuse_pair("a --slice plot draws one model");
      const svg::Figure fig = plot_slice(run, registry, *a);
      const std::string out = a->output.empty() ? a->run + "/model.svg" : a->output;
      save_plot(fig, out);
      return 0;
    }
    if (!a->slice.empty()) {
      // A run over a plain box: its parameters are real and linear, the box's own space (audit, session 48: --slice
      // was refused here, so a 7-D run could not be drawn at all).
      RunFolder boxed = run;
      boxed.space = std::make_shared<const SearchSpace>(SearchSpace::from_box(run.domain.box, run.names));
      refuse_pair("a --slice plot draws one model");
      save_plot(plot_slice(boxed, registry, *a), a->output.empty() ? a->run + "/model.svg" : a->output);
      return 0;
    }
    const Index d = run.domain.box.dim();
    if (d != 1 && d != 2)
      throw InputError(fmt::format("{}: the task has {} parameters; plot draws 1-D and 2-D tasks whole, and one "
                                   "parameter of any run with --slice NAME (one of {})",
                                   a->run, d, join(run.names)));
    if (d == 2) refuse_pair("a 2-D plot draws one model");
    if (d == 1 && !a->surrogate.empty())
      throw InputError(fmt::format("{}: --surrogate names the model of a 2-D or --slice plot; a 1-D plot draws two, "
                                   "named by --gp and --vhgp", a->run));
    const svg::Figure fig = d == 1 ? plot_1d(run, registry, *a, gp_opt->count() > 0, vh_opt->count() > 0)
                                   : plot_2d(run, registry, *a);
    const std::string out = a->output.empty() ? a->run + "/model.svg" : a->output;
    save_plot(fig, out);
    return 0;
  };
}

}  // namespace varbo::cli

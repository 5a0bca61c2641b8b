// Reads a run folder written by `varbo run` (run_writer.cpp) back into memory.
#include "varbo/space_wrappers.hpp"
#include "varbo/run_folder.hpp"

#include "../study/stored_plugin_paths.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>

#include "varbo/csv.hpp"
#include "varbo/errors.hpp"
#include "varbo/regular_file.hpp"
#include "varbo/loader.hpp"
#include "varbo/log.hpp"
#include "varbo/math.hpp"
#include "varbo/numbers.hpp"
#include "varbo/text.hpp"
#include "varbo/store.hpp"
#include "varbo/study_api.hpp"
#include "../study/study_impl.hpp"

#include <yaml-cpp/yaml.h>

namespace fs = std::filesystem;

namespace varbo {

namespace {

double parse_number(const std::string& text, const std::string& where) {
  const std::optional<double> v = parse_decimal(text);
  if (!v) throw InputError(fmt::format("{}: expected a decimal number, got '{}'", where, text));
  return *v;
}

/// The fits logged in model.yaml, the warm start of an offline refit. Only a start: a file that cannot be read (cut
/// short by a kill or a full disk while appended) or an entry that is not numbers is said and skipped, the refit
/// then starts from the defaults; it blocked `select`, `plot` and `rescore` (and a value written as "inf" by older
/// versions was an internal error).
std::vector<Hyperparameters> read_model_yaml(const std::string& file) {
  std::vector<Hyperparameters> out;
  if (!fs::exists(file)) return out;
  if (!absent_or_regular_file(file)) {  // a FIFO blocked forever, a directory was an internal error
    log_warn("{}: not a regular file; the model is fitted from its defaults, without the run's last hyperparameters",
             file);
    return out;
  }
  YAML::Node root;
  try {
    root = YAML::LoadFile(file);
  } catch (const YAML::Exception& e) {
    log_warn("{}: cannot parse ({}); the model is fitted from its defaults, without the run's last hyperparameters",
             file, e.what());
    return out;
  }
  if (!root.IsSequence()) return out;  // only the header comment: no fit happened
  for (const auto& entry : root) {
    Hyperparameters h;
    try {
      const YAML::Node hp = entry["hyperparameters"];
      if (hp && hp.IsMap())
        for (const auto& kv : hp) {
          double v = 0;
          const std::string text = kv.second.IsScalar() ? kv.second.Scalar() : "";
          if (text == "inf" || text == "-inf" || text == "nan" || text == "-nan")  // written so before .inf
            v = strtod_c(text.c_str(), nullptr);
          else if (const auto d = parse_decimal(text))  // the C locale's '.', whatever the host's locale
            v = *d;
          else
            v = kv.second.as<double>();
          h.push_back({kv.first.as<std::string>(), v});
        }
    } catch (const YAML::Exception& e) {
      log_warn("{}: fit {} is not a map of numbers ({}); skipped", file, out.size() + 1, e.what());
      continue;
    }
    out.push_back(std::move(h));
  }
  return out;
}

}  // namespace

Vec unit_point(const RunFolder& run, const Vec& theta) {
  return run.space ? run.space->encode(theta) : Vec(Box::unit(theta.size()).clamp(to_unit(theta, run.domain.box)));
}

Registry& run_folder_registry(const std::string& folder) {
  const std::string cfg = folder + "/config.resolved.yaml";
  std::error_code ec;
  if (!fs::exists(cfg, ec)) return default_registry();  // load_run_folder says what is missing
  const std::vector<std::string> paths =
      study_detail::trusted_plugin_folders(plugin_paths_of(ConfigNode::load_file(cfg)), cfg);
  if (paths.empty()) return default_registry();
  struct Loaded {
    Registry registry;
    PluginLoader loader{registry};
  };
  static std::mutex mutex;
  // Never destroyed, like what it holds: a static map's destructor at exit left its registries unreachable, a leak
  // to LeakSanitizer.
  static auto* loaded = new std::map<std::vector<std::string>, Loaded*>();
  const std::lock_guard<std::mutex> lock(mutex);
  Loaded*& slot = (*loaded)[paths];
  if (!slot) {
    auto* fresh = new Loaded();  // intentionally leaked: plugins are never unloaded
    fresh->loader.load_default(paths);
    slot = fresh;
  }
  return slot->registry;
}

namespace {
/// select/plot/rescore read trials.csv and config.resolved.yaml, which a run writes; results recorded since (an
/// `observe`, a worker) and a hand-edited config were used in silence: a new best trial left out, θ chosen in
/// bounds the study never had (red team, session 28). Said, when the folder's study.db can be read.
void warn_if_behind_its_study(const RunFolder& run) {
  const std::string db = run.folder + "/study.db";
  if (!fs::exists(db)) return;
  try {
    const std::unique_ptr<StudyStore> store = open_store(db);
    const auto finished = static_cast<Index>(store->next_finish_seq());
    if (finished > run.trials)
      log_warn("{}: its study holds {} finished trials, trials.csv {}: results recorded since the run wrote it are "
               "not used here; `varbo run --resume {}` rewrites the folder",
               run.folder, finished, run.trials, shell_word(run.folder));
    if (const auto identity = store->meta(store_key::kIdentity);
        identity && !study_detail::same_identity(*identity, study_identity(run.study)))
      log_warn("{}/config.resolved.yaml differs from the study's configuration ({}): an edit of that file changes "
               "nothing of the study, and what is computed here follows the file",
               run.folder, study_detail::first_difference(*identity, study_identity(run.study)));
  } catch (const std::exception& e) {
    // A study.db of random bytes skipped the comparison in silence (red team, session 34): said, the command goes on.
    log_warn("{}: the run folder's study.db cannot be read ({}); trials.csv is used without checking that it is up "
             "to date with its study",
             run.folder, safe_text(e.what(), 200));
  }
}
}  // namespace

RunFolder load_run_folder(const std::string& folder, const Registry& registry) {
  RunFolder run;
  run.folder = folder;
  const std::string cfg = folder + "/config.resolved.yaml";
  const std::string csv = folder + "/trials.csv";
  if (!fs::is_directory(folder)) throw InputError(fmt::format("{}: no such run folder", folder));
  if (!fs::exists(cfg)) throw InputError(fmt::format("{}: missing (is this a varbo run folder?)", cfg));
  if (!fs::exists(csv)) throw InputError(fmt::format("{}: missing (is this a varbo run folder?)", csv));
  run.study = parse_study(ConfigNode::load_file(cfg), registry);

  BuildContext tctx;
  tctx.seed = run.study.seed;
  const std::unique_ptr<Task> task = registry.create<Task>(run.study.task, tctx);
  run.space = resolve_study_space(run.study, *task, run.domain);
  const Index d = run.domain.box.dim();
  run.names = run.domain.names;
  run.initial_point = run.study.initial_point ? run.study.initial_point : task->initial_point();
  for (Index i = static_cast<Index>(run.names.size()); i < d; ++i) run.names.push_back(fmt::format("x{}", i + 1));

  require_regular_file(csv, "the run's table of trials, a CSV file");
  std::ifstream in(csv);
  std::string line;
  if (!std::getline(in, line)) throw InputError(fmt::format("{}: empty file (expected a header line)", csv));
  const std::vector<std::string> header = split_csv_line(line);
  auto column = [&](const std::string& name) {
    for (std::size_t i = 0; i < header.size(); ++i)
      if (header[i] == name) return i;
    // The header holds a name's control characters escaped (csv_text: a newline as the two characters "\n"), as
    // it does a choice label's (SearchSpace::parse_value): names: ["a\nb"] ran, then `select`/`plot` said "no
    // column 'a<newline>b'".
    for (std::size_t i = 0; i < header.size(); ++i)
      if (header[i] == printable(name)) return i;
    throw InputError(fmt::format("{}: no column '{}' (header: {})", csv, printable(name), join(header)));
  };
  // The writer's layout (run_writer.cpp): index, phase, the parameters in order, cost, ok, the components, the
  // timings. Read by position when the header has it: a parameter may be named like a fixed column (`index`,
  // `cost`, `phase`), and the first column of that name was then read as it (`select` took the trial number for θ).
  const std::size_t d_names = run.names.size();
  const auto named = [&](std::size_t i, const std::string& name) {
    return i < header.size() && (header[i] == name || header[i] == printable(name));
  };
  bool positional = named(0, "index") && named(1, "phase") && named(2 + d_names, "cost") && named(3 + d_names, "ok");
  for (std::size_t j = 0; positional && j < d_names; ++j) positional = named(2 + j, run.names[j]);
  std::vector<std::size_t> xcols;
  for (std::size_t j = 0; j < d_names; ++j) xcols.push_back(positional ? 2 + j : column(run.names[j]));
  const std::size_t cost_col = positional ? 2 + d_names : column("cost");
  const std::size_t ok_col = positional ? 3 + d_names : column("ok");
  const std::size_t phase_col = positional ? 1 : column("phase");

  // Cost components sit between `ok` and the timings (fit_seconds), in the task's order.
  std::size_t comp_end = header.size();
  for (std::size_t i = ok_col + 1; i < header.size(); ++i)
    if (header[i] == "fit_seconds") comp_end = i;
  for (std::size_t i = ok_col + 1; i < comp_end; ++i) run.components.push_back(header[i]);

  std::vector<Vec> thetas, values, failed_thetas;
  std::vector<double> costs;
  int lineno = 1;
  while (std::getline(in, line)) {
    ++lineno;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    const std::vector<std::string> cells = split_csv_line(line);
    if (cells.size() != header.size())
      throw InputError(fmt::format("{}:{}: expected {} values (as in the header), found {}", csv, lineno,
                                   header.size(), cells.size()));
    ++run.trials;
    const std::string where = fmt::format("{}:{}", csv, lineno);
    auto theta_of_row = [&] {
      Vec t(d);
      for (Index j = 0; j < d; ++j) {
        const std::string& cell = cells[xcols[static_cast<std::size_t>(j)]];
        if (!run.space) {
          t[j] = parse_number(cell, where);
          continue;
        }
        try {  // labels for categories
          t[j] = run.space->parse_value(static_cast<std::size_t>(j), cell);
        } catch (const InputError& e) {
          throw InputError(fmt::format("{}: {}", where, e.what()));
        }
      }
      return t;
    };
    if (cells[ok_col] != "1") {
      // Failed trials inform no model (as in the algorithm), but `select` keeps its choices away from them.
      try {
        if (const Vec t = theta_of_row(); t.allFinite()) failed_thetas.push_back(t);
      } catch (const InputError&) {
      }
      continue;
    }
    const Vec t = theta_of_row();
    const double y = parse_number(cells[cost_col], where);
    if (!t.allFinite() || !std::isfinite(y)) continue;
    // The runner keeps θ in the domain: a θ far outside it (x1 = 1e6 for Branin) is not this run's record, and
    // was fitted as given, in silence, changing the selection (red team, session 34). Tolerance: the last digits
    // of a number written in user units.
    if (!run.space)
      for (Index j = 0; j < d; ++j) {
        const double lo = run.domain.box.lower[j], hi = run.domain.box.upper[j], slack = 1e-9 * (hi - lo);
        if (t[j] < lo - slack || t[j] > hi + slack)
          throw InputError(fmt::format("{}: {} = {} lies outside the domain [{}, {}]; this row is not a trial of the "
                                       "run (edited or damaged file?)",
                                       where, printable(run.names[static_cast<std::size_t>(j)]), t[j], lo, hi));
      }
    Vec v(static_cast<Index>(run.components.size()));
    for (Index j = 0; j < v.size(); ++j) {
      const std::string& cell = cells[ok_col + 1 + static_cast<std::size_t>(j)];
      v[j] = (cell.empty() || cell == "nan") ? std::nan("") : parse_number(cell, where);  // "nan": not reported
    }
    values.push_back(v);
    thetas.push_back(t);
    costs.push_back(y);
    run.phases.push_back(cells[phase_col]);
  }
  const Index n = static_cast<Index>(thetas.size());
  run.theta.resize(n, d);
  run.cost.resize(n);
  run.data = Dataset::empty(run.space ? run.space->encoded_dim() : d);
  run.component_values.resize(n, static_cast<Index>(run.components.size()));
  for (Index i = 0; i < n; ++i) {
    run.component_values.row(i) = values[static_cast<std::size_t>(i)].transpose();
    run.theta.row(i) = thetas[static_cast<std::size_t>(i)].transpose();
    run.cost[i] = costs[static_cast<std::size_t>(i)];
    // The same clamp as the runner: a θ written in user units maps back into the unit cube.
    const Vec& t = thetas[static_cast<std::size_t>(i)];
    run.data.add(unit_point(run, t), run.cost[i]);
  }
  run.failed.resize(static_cast<Index>(failed_thetas.size()), run.data.dim());
  for (std::size_t i = 0; i < failed_thetas.size(); ++i)
    run.failed.row(static_cast<Index>(i)) = unit_point(run, failed_thetas[i]).transpose();
  run.fits = read_model_yaml(folder + "/model.yaml");
  warn_if_behind_its_study(run);
  return run;
}

const ResolvedComponent* run_surrogate_spec(const RunFolder& run) {
  const ComponentInfo* info = run.study.algorithm.info;
  if (info == nullptr) return nullptr;
  for (const auto& o : info->options)
    if (o.name == "surrogate" && o.type == OptionType::Component && run.study.algorithm.options.is_set("surrogate"))
      return &run.study.algorithm.options.component("surrogate");
  return nullptr;
}

std::unique_ptr<Surrogate> make_run_surrogate(const RunFolder& run, const ResolvedComponent& spec,
                                              const Registry& registry, std::uint64_t seed, bool warm_start) {
  BuildContext ctx;
  ctx.dim = run.space ? run.space->encoded_dim() : run.domain.box.dim();
  ctx.seed = seed;
  std::unique_ptr<Surrogate> model = respect_types(registry.create<Surrogate>(spec, ctx), run.space);
  const ResolvedComponent* own = run_surrogate_spec(run);
  // The warm start is for the run's own model only: a --surrogate of the same type with other options (a prior
  // mean, given hyperparameters) was overridden by the run's last fit (red team, session 24).
  const bool same_model = own != nullptr && own->info == spec.info &&
                          YAML::Dump(own->resolved()) == YAML::Dump(spec.resolved());
  if (warm_start && !run.fits.empty() && same_model && !run.fits.back().empty()) {
    // Starting values only. The gp's `mean` is not one: set, it fixes the constant mean, so the model of all the
    // trials kept the mean of the last fit's data (the first N - 1 trials, or a trust region's attempt: -46.3
    // where the data mean was -35.4; red team, session 24). Left out, it is the data mean again.
    Hyperparameters start;
    for (const Hyperparameter& h : run.fits.back())
      if (h.name != "mean") start.push_back(h);
    try {
      model->set_hyperparameters(start);
    } catch (const Error& e) {
      log_warn("{}/model.yaml: last hyperparameters not usable as a start ({}); fitting from the defaults",
               run.folder, e.what());
    }
  }
  return model;
}

FitReport fit_run_surrogate(Surrogate& model, const RunFolder& run, std::uint64_t seed) {
  if (run.data.size() < 2)
    throw InputError(fmt::format("{}: {} successful trials; at least 2 are needed to fit a model", run.folder,
                                 run.data.size()));
  Rng rng = Rng(seed).stream(0xf17);
  FitReport rep = model.fit(run.data, rng);
  if (!rep.ok) log_warn("{}: model fit: {}", run.folder, rep.report());
  if (!model.ready()) throw NumericalError(fmt::format("{}: the model fit failed: {}", run.folder, rep.message));
  return rep;
}

}  // namespace varbo

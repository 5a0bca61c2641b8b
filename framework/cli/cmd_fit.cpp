// `varbo fit`: fit (or only condition) a surrogate on a CSV and print hyperparameters, objective and
// predictions as JSON — for checking a model against another implementation.
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>

#include "varbo/background_ticker.hpp"
#include "cli_parse.hpp"
#include "commands.hpp"
#include "component_arg.hpp"
#include "varbo/csv.hpp"
#include "varbo/errors.hpp"
#include "varbo/fit.hpp"
#include "varbo/loader.hpp"
#include "varbo/log.hpp"
#include "varbo/parallel.hpp"
#include "varbo/text.hpp"

namespace varbo::cli {

namespace {

/// Costs and coordinates are squared inside every model (standardization, kernels): beyond this magnitude the
/// squares overflow and a fit fails deep inside with no hint at the data.
constexpr double kMaxMagnitude = 1e150;

/// Finite, moderate values in the used columns; errors name the file, line and column.
void check_values(const CsvTable& t, const std::vector<Index>& cols, const std::string& file, bool predict = false) {
  for (Index r = 0; r < t.values.rows(); ++r)
    for (Index c : cols) {
      const double v = t.values(r, c);
      const int line = t.lines[static_cast<std::size_t>(r)];
      const std::string& name = t.columns[static_cast<std::size_t>(c)];
      if (!std::isfinite(v))
        throw InputError(fmt::format("{}:{}: column '{}': {} is not a finite number ({})", file, line, name, v,
                                     predict ? "varbo fit predicts at finite θ only"
                                             : "varbo fit needs finite θ and y; drop failed trials"));
      if (std::abs(v) > kMaxMagnitude)
        throw InputError(fmt::format("{}:{}: column '{}': {} is too large in magnitude (at most {:g}: the models "
                                     "square it); rescale the column",
                                     file, line, name, v, kMaxMagnitude));
    }
}

/// Past a few seconds, a line on stderr every so often (at 5, 10, …, 30 s, then every 30 s): a large fit must not
/// look hung.
BackgroundTicker progress_line(std::string what) {
  auto at = [](int k) { return k < 6 ? 5.0 * (k + 1) : 30.0 * (k - 4); };
  return BackgroundTicker(at, [what = std::move(what), at](int k) {
    std::fprintf(stderr, "varbo fit: fitting %s: %.0f s so far\n", what.c_str(), at(k));
    return true;
  });
}

/// 0, 1, 2, … or 1, 2, 3, …: the column a spreadsheet or pandas adds.
bool is_row_number(const Vec& v) {
  if (v.size() == 0 || !(v(0) == 0 || v(0) == 1)) return false;
  for (Index r = 1; r < v.size(); ++r)
    if (v(r) != v(r - 1) + 1) return false;
  return true;
}

}  // namespace

Runner add_fit(CLI::App& app) {
  auto* cmd = app.add_subcommand("fit", "Fit a surrogate to a CSV of θ columns and a 'y' column; print JSON");
  struct Args {
    std::string surrogate, data, predict, target = "y", seed = "1";
    std::vector<std::string> columns;
    bool no_optimize = false;
    int threads = 0;
  };
  auto a = std::make_shared<Args>();
  cmd->add_option("--surrogate", a->surrogate,
                  "a YAML file (a surrogate map {type: gp, ...} or a study file with a 'surrogate:' key), a "
                  "surrogate name (gp, vhgp) or inline YAML such as '{type: gp, kernel: se_ard}'")
      ->required();
  cmd->add_option("--data", a->data, "CSV with θ columns and a 'y' column (θ used as given: the model's coordinates)")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("--predict", a->predict, "CSV of points (same θ columns) to predict at")->check(CLI::ExistingFile);
  cmd->add_option("--columns", a->columns,
                  "θ columns to use; other columns may hold text (default: every column but the target, and a row "
                  "number named i or index)")
      ->type_name("NAME[,NAME...]");
  cmd->add_option("--target", a->target, "the column of costs (default y; e.g. cost for a trials.csv)");
  cmd->add_flag("--no-optimize", a->no_optimize, "keep the hyperparameters given in the YAML; only condition");
  cmd->add_option("--seed", a->seed, "random seed for restarts");
  cmd->add_option("--threads", a->threads, "worker threads (0 = all)")->check(integer_in(0, 2147483647));
  return [a]() {
    ThreadLimit limit(a->threads);
    ConfigNode node = component_arg(a->surrogate, "surrogate", "--surrogate");
    // A bare name (`--surrogate vhgp`) as the map it stands for, so that a message about one of its keys names the
    // option: it said "<none>: key 'hyperparameters'" (audit, session 47).
    if (node.is_scalar() && node.scalar().find_first_of("{}[]:\n#'\"") == std::string::npos)
      node = ConfigNode::parse("{type: " + node.scalar() + "}", "--surrogate");
    const auto seed = static_cast<std::uint64_t>(integer_flag(a->seed, "--seed", 0));  // not saturated
    const std::string& target = a->target;
    const std::vector<std::string> chosen =
        a->columns.empty() ? std::vector<std::string>{} : list_items(a->columns, "--columns", "x1,x2");
    // With --columns only the columns used are read as numbers: notes, dates or a trials table's text may sit beside.
    const CsvTable data = read_csv(a->data, [&](const std::string& name) {
      return chosen.empty() || name == target || std::find(chosen.begin(), chosen.end(), name) != chosen.end();
    });
    const Index ycol = data.column(target);
    if (ycol < 0)
      throw InputError(fmt::format("{}: no column named '{}' (the costs{})", a->data, target,
                                   target == "y" ? "; name another with --target" : ", from --target"));
    std::vector<Index> xcols;
    std::vector<std::string> xnames;
    if (!chosen.empty()) {
      for (const auto& name : chosen) {
        if (name == target)
          throw InputError(fmt::format("--columns: '{}' is the target (the costs) and cannot also be a θ column", name));
        if (std::find(xnames.begin(), xnames.end(), name) != xnames.end())
          throw InputError(fmt::format("--columns: '{}' is named twice", name));
        const Index c = data.column(name);
        if (c < 0) throw InputError(fmt::format("{}: no column named '{}' (from --columns)", a->data, name));
        xcols.push_back(c);
        xnames.push_back(name);
      }
    } else {
      for (Index c = 0; c < static_cast<Index>(data.columns.size()); ++c) {
        if (c == ycol) continue;
        const std::string& name = data.columns[static_cast<std::size_t>(c)];
        // A row number (0, 1, 2, … or 1, 2, 3, …) is not a coordinate; a gain named i (a PID's) is one.
        if (name == "i" && is_row_number(data.values.col(c))) {
          std::fprintf(stderr, "varbo fit: column '%s' holds row numbers: not a θ column (name it in --columns to use it)\n",
                       name.c_str());
          continue;
        }
        // pandas' index, written by DataFrame.to_csv: "index" (after reset_index) or a header "Unnamed: 0" (after
        // read_csv of a file that had one). Rows filtered in pandas leave gaps (0, 2, 3, 5), so its values are no
        // test; they became a θ column in silence (red team, session 30).
        const bool pandas_unnamed = name.rfind("Unnamed: ", 0) == 0 && name.size() > 9 &&
                                    name.find_first_not_of("0123456789", 9) == std::string::npos;
        if (name == "index" || pandas_unnamed) {
          const auto col = data.values.col(c);
          const bool integers = col.size() > 0 && (col.array() == col.array().round()).all();
          if (name == "index" || integers) {
            std::fprintf(stderr,
                         "varbo fit: column '%s' is a pandas index (DataFrame.to_csv(index=False) leaves it out): not "
                         "a θ column (name it in --columns to use it)\n",
                         name.c_str());
            continue;
          }
          throw InputError(fmt::format("{}: column '{}' has no name of its own (pandas calls a header cell left "
                                       "empty so): name it in the file, or choose the θ columns with --columns",
                                       a->data, name));
        }
        xcols.push_back(c);
        xnames.push_back(name);
      }
    }
    if (xcols.empty()) throw InputError(fmt::format("{}: no θ columns besides '{}'", a->data, target));
    // 10^6 columns ran for minutes without a word (red team, session 34); the external task's limit on dim.
    constexpr std::size_t kMaxColumns = 10000;
    if (xcols.size() > kMaxColumns)
      throw InputError(fmt::format("{}: {} θ columns; at most {} (choose the θ columns with --columns)", a->data,
                                   xcols.size(), kMaxColumns));
    if (data.values.rows() == 0)
      throw InputError(fmt::format("{}: no data rows after the header; a model needs at least one (θ, y) row", a->data));
    std::vector<Index> used = xcols;
    used.push_back(ycol);
    check_values(data, used, a->data);
    Dataset ds;
    ds.X.resize(data.values.rows(), static_cast<Index>(xcols.size()));
    for (std::size_t j = 0; j < xcols.size(); ++j) ds.X.col(static_cast<Index>(j)) = data.values.col(xcols[j]);
    ds.y = data.values.col(ycol);
    if (const double top = ds.y.cwiseAbs().maxCoeff(); top > 0 && top < 1e-150)
      throw InputError(fmt::format("{}: column 'y': every value is at most {:g} in magnitude: the models square it, "
                                   "which underflows below about 1e-154; rescale the column",
                                   a->data, top));

    // Identical rows (θ and y) are exact replicates of a deterministic cost to the noise models (the gp's noise
    // bound from replicates is then 0): a row pasted twice into noisy data forced the noise to its floor in silence.
    for (Index r = 1; r < ds.size(); ++r)
      for (Index q = 0; q < r; ++q)
        if (ds.y(r) == ds.y(q) && ds.X.row(r) == ds.X.row(q)) {
          std::fprintf(stderr,
                       "varbo fit: %s: lines %d and %d are identical (θ and y): to a model, exact replicates of a "
                       "deterministic cost (the noise goes to its floor); drop duplicated rows if they are copies\n",
                       a->data.c_str(), data.lines[static_cast<std::size_t>(q)], data.lines[static_cast<std::size_t>(r)]);
          r = ds.size();  // once
          break;
        }

    Registry& registry = default_registry();
    SurrogateFit fitted;
    {
      const BackgroundTicker progress = progress_line(fmt::format(
          "{} on {} points × {} dimensions", registry.resolve(Kind::Surrogate, node).info->name, ds.size(), ds.dim()));
      fitted = fit_surrogate(registry, node, ds, seed, !a->no_optimize, a->data);
    }
    const ResolvedComponent& rc = fitted.component;
    const FitReport& rep = fitted.report;
    const auto& model = fitted.model;
    // Conditioned on given hyperparameters: what the model says of that (the gp's kernel when its YAML leaves the
    // choice to a fit, audit session 48) on stderr too, not only inside the JSON.
    if (a->no_optimize && !rep.message.empty())
      std::fprintf(stderr, "varbo fit: %s: %s\n", rc.info->name.c_str(), safe_text(rep.message).c_str());

    nlohmann::json j;
    j["surrogate"] = rc.info->full_name();
    j["columns"] = xnames;  // the order of every per-dimension value below (lengthscales, x)
    j["target"] = target;
    j["n"] = ds.size();
    j["dim"] = ds.dim();
    j["optimized"] = rep.optimized;
    j["ok"] = rep.ok;
    j["objective"] = rep.objective;
    j["objective_without_prior"] = rep.log_likelihood;
    j["log_prior"] = rep.log_prior;
    j["message"] = rep.message;
    for (const auto& h : model->hyperparameters()) j["hyperparameters"][h.name] = h.value;
    for (const auto& [name, v] : model->state()) j["state"][name] = std::vector<double>(v.data(), v.data() + v.size());
    if (!a->predict.empty()) {
      const CsvTable pts = read_csv(a->predict, [&](const std::string& name) {
        return std::find(xnames.begin(), xnames.end(), name) != xnames.end();
      });
      std::vector<Index> pcols;
      for (const auto& name : xnames) {
        const Index c = pts.column(name);
        if (c < 0) throw InputError(fmt::format("{}: missing column '{}'", a->predict, name));
        pcols.push_back(c);
      }
      check_values(pts, pcols, a->predict, true);
      if (!model->ready())
        throw NumericalError(fmt::format("{}: the {} model is not usable after the fit ({}); no predictions",
                                         a->data, rc.info->name, rep.message));
      nlohmann::json preds = nlohmann::json::array();
      for (Index r = 0; r < pts.values.rows(); ++r) {
        Vec x(ds.dim());
        for (std::size_t k = 0; k < pcols.size(); ++k) x[static_cast<Index>(k)] = pts.values(r, pcols[k]);
        Prediction p;
        try {
          p = model->predict(x, false);
        } catch (const Error&) {
          throw;
        } catch (const std::exception& e) {
          throw NumericalError(fmt::format("{}:{}: prediction failed: {}", a->predict, pts.lines[static_cast<std::size_t>(r)], e.what()));
        }
        preds.push_back({{"x", std::vector<double>(x.data(), x.data() + x.size())},
                         {"mean", p.mean},
                         {"variance", p.total_var()},
                         {"latent_var", p.latent_var},
                         {"log_noise_mean", p.log_noise_mean},
                         {"log_noise_var", p.log_noise_var}});
      }
      j["predictions"] = preds;
    }
    std::printf("%s\n", j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace).c_str());
    return rep.ok ? 0 : 1;
  };
}

}  // namespace varbo::cli

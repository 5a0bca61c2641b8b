// `varbo fit`: fit (or only condition) a surrogate on a CSV and print hyperparameters, objective and
// predictions as JSON — for checking a model against another implementation.
#include <fmt/format.h>

#include <cstdio>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "varbo/csv.hpp"
#include "varbo/errors.hpp"
#include "varbo/loader.hpp"
#include "varbo/parallel.hpp"

namespace varbo::cli {

Runner add_fit(CLI::App& app) {
  auto* cmd = app.add_subcommand("fit", "Fit a surrogate to a CSV of θ columns and a 'y' column; print JSON");
  struct Args {
    std::string surrogate, data, predict;
    std::vector<std::string> columns;
    bool no_optimize = false;
    long long seed = 1;
    int threads = 0;
  };
  auto a = std::make_shared<Args>();
  cmd->add_option("--surrogate", a->surrogate,
                  "YAML file: a surrogate map ({type: gp, ...}) or a study file with a 'surrogate:' key")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("--data", a->data, "CSV with θ columns and a 'y' column (θ used as given: the model's coordinates)")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("--predict", a->predict, "CSV of points (same θ columns) to predict at")->check(CLI::ExistingFile);
  cmd->add_option("--columns", a->columns, "θ columns to use (default: every column but y, i and index)")
      ->delimiter(',');
  cmd->add_flag("--no-optimize", a->no_optimize, "keep the hyperparameters given in the YAML; only condition");
  cmd->add_option("--seed", a->seed, "random seed for restarts");
  cmd->add_option("--threads", a->threads, "worker threads (0 = all)");
  return [a]() {
    ThreadLimit limit(a->threads);
    ConfigNode root = ConfigNode::load_file(a->surrogate);
    ConfigNode node = root;
    if (root.has("surrogate")) node = root.child("surrogate");
    if (root.has("algorithm") && root.child("algorithm").has("surrogate"))
      node = root.child("algorithm").child("surrogate");
    const CsvTable data = read_csv(a->data);
    const Index ycol = data.column("y");
    if (ycol < 0) throw InputError(fmt::format("{}: no column named 'y' (the costs)", a->data));
    std::vector<Index> xcols;
    std::vector<std::string> xnames;
    if (!a->columns.empty()) {
      for (const auto& name : a->columns) {
        const Index c = data.column(name);
        if (c < 0) throw InputError(fmt::format("{}: no column named '{}' (from --columns)", a->data, name));
        xcols.push_back(c);
        xnames.push_back(name);
      }
    } else {
      for (Index c = 0; c < static_cast<Index>(data.columns.size()); ++c)
        if (c != ycol && data.columns[c] != "i" && data.columns[c] != "index") {
          xcols.push_back(c);
          xnames.push_back(data.columns[c]);
        }
    }
    if (xcols.empty()) throw InputError(fmt::format("{}: no θ columns besides 'y'", a->data));
    Dataset ds;
    ds.X.resize(data.values.rows(), static_cast<Index>(xcols.size()));
    for (std::size_t j = 0; j < xcols.size(); ++j) ds.X.col(static_cast<Index>(j)) = data.values.col(xcols[j]);
    ds.y = data.values.col(ycol);
    if (!ds.X.allFinite() || !ds.y.allFinite()) throw InputError(fmt::format("{}: non-finite values", a->data));

    Registry& registry = default_registry();
    ResolvedComponent rc = registry.resolve(Kind::Surrogate, node);
    BuildContext ctx;
    ctx.dim = ds.dim();
    ctx.seed = static_cast<std::uint64_t>(a->seed);
    auto model = registry.create<Surrogate>(rc, ctx);
    Rng rng(static_cast<std::uint64_t>(a->seed));
    FitReport rep = a->no_optimize ? model->condition(ds) : model->fit(ds, rng);

    nlohmann::json j;
    j["surrogate"] = rc.info->full_name();
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
      const CsvTable pts = read_csv(a->predict);
      nlohmann::json preds = nlohmann::json::array();
      for (Index r = 0; r < pts.values.rows(); ++r) {
        Vec x(ds.dim());
        for (std::size_t k = 0; k < xnames.size(); ++k) {
          const Index c = pts.column(xnames[k]);
          if (c < 0) throw InputError(fmt::format("{}: missing column '{}'", a->predict, xnames[k]));
          x[static_cast<Index>(k)] = pts.values(r, c);
        }
        const Prediction p = model->predict(x, false);
        preds.push_back({{"x", std::vector<double>(x.data(), x.data() + x.size())},
                         {"mean", p.mean},
                         {"variance", p.total_var()},
                         {"latent_var", p.latent_var},
                         {"log_noise_mean", p.log_noise_mean},
                         {"log_noise_var", p.log_noise_var}});
      }
      j["predictions"] = preds;
    }
    std::printf("%s\n", j.dump(2).c_str());
    return rep.ok ? 0 : 1;
  };
}

}  // namespace varbo::cli

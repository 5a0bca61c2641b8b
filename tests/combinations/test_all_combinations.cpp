// Runs a short seeded study on Branin for EVERY compatible combination of the loaded components:
// surrogate × acquisition × region × acquisition optimizer × initial-design sampler, and separately
// surrogate × fit optimizer and surrogate × kernel. The lists come from the registry at run time, so a new plugin adds its
// combinations with no edit here; only combinations whose capability tags don't match are skipped.
//
// VARBO_COMBINATIONS_WITH=NAME[,NAME...] runs only the combinations that include one of the named components (by
// name, plugin/name, or every component of a plugin by its plugin name): a third-party plugin's author checks the
// plugin's combinations without the whole matrix, e.g.
//   VARBO_PLUGIN_PATH=$PWD/build VARBO_COMBINATIONS_WITH=myplugin build/bin/test_all_combinations
#include <cmath>
#include <cstdlib>
#include <fmt/format.h>

#include "study_helpers.hpp"
#include "varbo/log.hpp"
#include "varbo_test.hpp"

using namespace varbo;

namespace {

std::vector<std::string> wanted_components() {
  std::vector<std::string> out;
  const char* env = std::getenv("VARBO_COMBINATIONS_WITH");
  std::string item;
  for (const char* c = env ? env : ""; ; ++c) {
    if (*c == ',' || *c == '\0') {
      if (!item.empty()) out.push_back(item);
      item.clear();
      if (*c == '\0') break;
    } else if (*c != ' ') {
      item += *c;
    }
  }
  return out;
}

/// Whether an item of VARBO_COMBINATIONS_WITH names component `c`: its name, plugin/name or plugin.
bool names_component(const std::string& item, const ComponentInfo& c) {
  return item == c.name || item == c.full_name() || item == c.plugin;
}

/// Whether VARBO_COMBINATIONS_WITH (unset: everything) names one of `parts`.
bool selected(std::initializer_list<const ComponentInfo*> parts) {
  static const std::vector<std::string> wanted = wanted_components();
  if (wanted.empty()) return true;
  for (const ComponentInfo* p : parts)
    for (const auto& w : wanted)
      if (names_component(w, *p)) return true;
  return false;
}

/// Whether VARBO_COMBINATIONS_WITH names a component of one of these kinds.
bool names_a(std::initializer_list<Kind> kinds) {
  for (const Kind k : kinds)
    for (const auto* c : test::registry().components(k))
      if (selected({c})) return true;
  return false;
}

/// At the end of each case. Under a filter a case may take none of the named components (an acquisition plugin has no
/// kernel combinations): then it checks just that; a named component that took part in no combination fails it.
void check_ran(int ran, std::initializer_list<Kind> kinds) {
  if (wanted_components().empty()) {
    CHECK(ran > 0);
  } else if (ran == 0) {
    INFO("VARBO_COMBINATIONS_WITH=" << std::getenv("VARBO_COMBINATIONS_WITH"));
    CHECK_MESSAGE(!names_a(kinds), "a named component takes part in this case but ran in no combination (all "
                                   "incompatible by capability tags?)");
  }
}

bool has_option(const ComponentInfo& c, const std::string& name) {
  for (const auto& o : c.options)
    if (o.name == name) return true;
  return false;
}

// Cheaper settings where a component offers them, so hundreds of studies stay within the test budget.
std::string surrogate_yaml(const ComponentInfo& s, const std::string& fit_optimizer = "") {
  std::string y = fmt::format("{{type: {}", s.full_name());
  if (has_option(s, "restarts")) y += ", restarts: 2";
  if (!fit_optimizer.empty() && has_option(s, "fit_optimizer")) y += ", fit_optimizer: " + fit_optimizer;
  return y + "}";
}

struct Outcome {
  bool finite = true;
  double best_initial = INFINITY;
  double best_after = INFINITY;
  int rows = 0;
};

Outcome run_combination(const std::string& algorithm_yaml, const std::string& out, Index budget) {
  const std::string yaml = fmt::format(
      "task: {{type: branin}}\nbudget: {}\nseed: 11\noutput: {}\nalgorithm: {}\n", budget, out, algorithm_yaml);
  test::run_yaml(yaml, test::registry());
  auto rows = test::read_rows(out + "/trials.csv");
  Outcome o;
  const int phase = test::column_of(rows[0], "phase"), cost = test::column_of(rows[0], "cost");
  for (std::size_t i = 1; i < rows.size(); ++i) {
    const double c = std::stod(rows[i][static_cast<std::size_t>(cost)]);
    o.finite = o.finite && std::isfinite(c);
    double& best = rows[i][static_cast<std::size_t>(phase)] == "initial" ? o.best_initial : o.best_after;
    best = std::min(best, c);
    ++o.rows;
  }
  return o;
}

std::vector<std::vector<std::string>> trials_without_timings(const std::string& folder) {
  auto rows = test::read_rows(folder + "/trials.csv");
  std::vector<int> drop;
  for (const char* c : {"fit_seconds", "acquisition_seconds", "evaluation_seconds"}) drop.push_back(test::column_of(rows[0], c));
  for (auto& r : rows)
    for (int i = static_cast<int>(r.size()) - 1; i >= 0; --i)
      if (std::find(drop.begin(), drop.end(), i) != drop.end()) r.erase(r.begin() + i);
  return rows;
}

/// Issue 11 item 8: a seed fixes a run whatever the thread count. Runs `algorithm_yaml` on noisy Branin with
/// 1 and 2 threads and compares the trials (without timings).
bool same_with_1_and_2_threads(const std::string& algorithm_yaml, const std::string& out, Index budget) {
  const std::string yaml = fmt::format("task: {{type: branin, noise_std: 1.0}}\nbudget: {}\nseed: 7\nalgorithm: {}\n",
                                       budget, algorithm_yaml);
  RunOverrides one, two;
  one.threads = 1;
  one.output = out + "/t1";
  two.threads = 2;
  two.output = out + "/t2";
  test::run_yaml(yaml, test::registry(), one);
  test::run_yaml(yaml, test::registry(), two);
  const auto a = trials_without_timings(out + "/t1"), b = trials_without_timings(out + "/t2");
  return a.size() == static_cast<std::size_t>(budget) + 1 && a == b;
}

}  // namespace

TEST_CASE("VARBO_COMBINATIONS_WITH names loaded components") {
  Registry& r = test::registry();
  for (const auto& w : wanted_components()) {
    bool found = false;
    for (const Kind kind : {Kind::Surrogate, Kind::Acquisition, Kind::Region, Kind::Optimizer, Kind::Sampler,
                            Kind::Algorithm, Kind::Kernel})
      for (const auto* c : r.components(kind)) found = found || names_component(w, *c);
    INFO("VARBO_COMBINATIONS_WITH item '" << w << "'");
    CHECK_MESSAGE(found, "names no loaded surrogate, acquisition, region, optimizer, sampler, algorithm or kernel "
                         "(is its folder on VARBO_PLUGIN_PATH?)");
  }
}

TEST_CASE("every surrogate x region x acquisition optimizer, and every algorithm, is the same with 1 and 2 threads") {
  set_log_level(LogLevel::Error);
  Registry& r = test::registry();
  const std::string out = test::temp_folder("thread_combinations");
  const ComponentInfo* ei = nullptr;
  const ComponentInfo* sobol = nullptr;
  for (const auto* a : r.components(Kind::Acquisition))
    if (a->name == "ei") ei = a;
  for (const auto* m : r.components(Kind::Sampler))
    if (m->name == "sobol") sobol = m;
  REQUIRE(ei != nullptr);
  REQUIRE(sobol != nullptr);
  int ran = 0;
  for (const auto* s : r.components(Kind::Surrogate))
    for (const auto* g : r.components(Kind::Region))
      for (const auto* o : r.components(Kind::Optimizer)) {
        if (!compatible({s, ei, g, o, sobol}) || !selected({s, ei, g, o, sobol})) continue;
        INFO(s->name << " + " << g->name << " + " << o->name);
        const std::string algo = fmt::format(
            "{{type: bo, initial_points: 5, initial_design: {}, surrogate: {}, region: {}, acquisition_optimizer: {}}}",
            sobol->full_name(), surrogate_yaml(*s), g->full_name(), o->full_name());
        CHECK(same_with_1_and_2_threads(algo, out, 8));
        ++ran;
      }
  for (const auto* a : r.components(Kind::Algorithm)) {
    if (a->name == "bo" || !selected({a})) continue;  // bo: covered above
    INFO(a->name);
    CHECK(same_with_1_and_2_threads(fmt::format("{{type: {}}}", a->full_name()), out, 12));
    ++ran;
  }
  MESSAGE(fmt::format("compared {} configurations across thread counts", ran));
  check_ran(ran, {Kind::Surrogate, Kind::Region, Kind::Optimizer, Kind::Algorithm});
}

TEST_CASE("every compatible surrogate x acquisition x region x optimizer x sampler combination improves on Branin") {
  set_log_level(LogLevel::Error);
  Registry& r = test::registry();
  const auto surrogates = r.components(Kind::Surrogate);
  const auto acquisitions = r.components(Kind::Acquisition);
  const auto regions = r.components(Kind::Region);
  const auto optimizers = r.components(Kind::Optimizer);
  const auto samplers = r.components(Kind::Sampler);
  REQUIRE(!surrogates.empty());
  REQUIRE(!acquisitions.empty());
  REQUIRE(!regions.empty());
  REQUIRE(!optimizers.empty());
  REQUIRE(!samplers.empty());
  const std::string out = test::temp_folder("combinations");
  int ran = 0, skipped = 0;
  const Index budget = 15, initial = 5;
  for (const auto* s : surrogates)
    for (const auto* a : acquisitions)
      for (const auto* g : regions)
        for (const auto* o : optimizers)
          for (const auto* m : samplers) {
            std::string why;
            if (!selected({s, a, g, o, m})) continue;
            if (!compatible({s, a, g, o, m}, &why)) {
              ++skipped;
              continue;
            }
            const std::string name = fmt::format("{} + {} + {} + {} + {}", s->name, a->name, g->name, o->name, m->name);
            INFO(name);
            const std::string algo = fmt::format(
                "{{type: bo, initial_points: {}, initial_design: {}, surrogate: {}, acquisition: {}, region: {}, "
                "acquisition_optimizer: {}}}",
                initial, m->full_name(), surrogate_yaml(*s), a->full_name(), g->full_name(), o->full_name());
            Outcome res;
            CHECK_NOTHROW(res = run_combination(algo, out, budget));
            CHECK(res.rows == budget);
            CHECK(res.finite);
            CHECK(res.best_after < res.best_initial);
            ++ran;
          }
  MESSAGE(fmt::format("ran {} combinations, skipped {} with unmet capability tags", ran, skipped));
  check_ran(ran, {Kind::Surrogate, Kind::Acquisition, Kind::Region, Kind::Optimizer, Kind::Sampler});
}

TEST_CASE("every surrogate fits with every optimizer as its hyperparameter fitter") {
  set_log_level(LogLevel::Error);
  Registry& r = test::registry();
  const std::string out = test::temp_folder("fit_combinations");
  int ran = 0;
  // The hyperparameter problem: smooth, in log space, where leaving the nominal box is harmless.
  ComponentInfo fit_problem;
  fit_problem.name = "hyperparameter fit";
  fit_problem.provides = {"problem:unbounded", "optimizer:constraints"};
  for (const auto* s : r.components(Kind::Surrogate)) {
    if (!has_option(*s, "fit_optimizer")) continue;
    for (const auto* o : r.components(Kind::Optimizer)) {
      if (!compatible({&fit_problem, o}) || !selected({s, o})) continue;
      INFO(s->name << " fitted by " << o->name);
      const std::string algo = fmt::format("{{type: bo, initial_points: 5, surrogate: {}}}",
                                           surrogate_yaml(*s, o->full_name()));
      Outcome res;
      CHECK_NOTHROW(res = run_combination(algo, out, 20));
      CHECK(res.finite);
      CHECK(res.best_after < res.best_initial);
      ++ran;
    }
  }
  check_ran(ran, {Kind::Optimizer});
}

TEST_CASE("every kernel option of every surrogate runs with every kernel, the same with 1 and 2 threads") {
  // Found by option kind (gp's `kernel`, vhgp's `kernel_f` and `kernel_g`), so a new surrogate or kernel adds its
  // combinations with no edit here (gp and vhgp take every kernel: 3 × 10 combinations today). A surrogate may refuse
  // a kernel it cannot use: then building it must fail with a ConfigError that names the kernel, never run wrongly.
  set_log_level(LogLevel::Error);
  Registry& r = test::registry();
  const std::string out = test::temp_folder("kernel_combinations");
  const auto kernels = r.components(Kind::Kernel);
  REQUIRE(!kernels.empty());
  int ran = 0, refused = 0;
  for (const auto* s : r.components(Kind::Surrogate))
    for (const auto& option : s->options) {
      if (option.type != OptionType::Component || option.component_kind != Kind::Kernel) continue;
      for (const auto* k : kernels) {
        if (!selected({s, k})) continue;
        // A composite gets two plain terms; any other kernel its defaults.
        const std::string kernel = has_option(*k, "terms")
                                       ? fmt::format("{{type: {}, terms: [se_ard, constant]}}", k->full_name())
                                       : fmt::format("{{type: {}}}", k->full_name());
        INFO(s->name << " with " << option.name << ": " << kernel);
        const std::string surrogate = surrogate_yaml(*s);
        const std::string with_kernel =
            fmt::format("{}, {}: {}}}", surrogate.substr(0, surrogate.size() - 1), option.name, kernel);
        BuildContext ctx;
        ctx.dim = 2;
        try {
          r.create<Surrogate>(with_kernel, ctx);
        } catch (const ConfigError& e) {
          CHECK(std::string(e.what()).find(k->name) != std::string::npos);
          ++refused;
          continue;
        }
        const std::string algo = fmt::format("{{type: bo, initial_points: 5, surrogate: {}}}", with_kernel);
        CHECK(same_with_1_and_2_threads(algo, out, 8));  // also: 8 trials recorded
        const auto rows = test::read_rows(out + "/t1/trials.csv");
        const int cost = test::column_of(rows[0], "cost");
        for (std::size_t i = 1; i < rows.size(); ++i) CHECK(std::isfinite(std::stod(rows[i][static_cast<std::size_t>(cost)])));
        ++ran;
      }
    }
  MESSAGE(fmt::format("ran {} surrogate x kernel combinations, {} refused by the surrogate", ran, refused));
  if (wanted_components().empty()) CHECK(ran >= static_cast<int>(kernels.size()));
  else check_ran(ran + refused, {Kind::Kernel});
}

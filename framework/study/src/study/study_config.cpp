// The top-level keys of a study file and their validation.
#include <fmt/format.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>

#include "varbo/errors.hpp"
#include "varbo/numbers.hpp"
#include "varbo/search_space_config.hpp"
#include "varbo/study.hpp"
#include "varbo/text.hpp"
#include "study_impl.hpp"

namespace varbo {

const std::vector<OptionSpec>& study_options() {
  static const std::vector<OptionSpec> specs = {
      opt::component("task", Kind::Task, "", "the task to optimize (its costs are minimized)").must(),
      opt::component("algorithm", Kind::Algorithm, "{type: bo}",
                     "the algorithm: bo (surrogate + acquisition + region + optimizers), random, ..."),
      opt::integer("budget", 30, "total number of task evaluations, initial design included").at_least(1),
      opt::integer("seed", 1, "random seed: fixes the whole run, whatever the thread count").at_least(0),
      opt::integer("threads", 0, "TBB worker threads (0 = all cores)").at_least(0),
      opt::string("output", "", "run folder (default: runs/<config file name>)"),
      opt::node("plugin_path", "", "a list of extra plugin files or folders (relative to the study file), searched after varbo's own plugins: a built-in name keeps meaning the built-in component"),
      opt::reals("initial_point", "", "θ0 in user units, for algorithms that start from a known policy"),
      opt::string("description", "", "free text, copied to the run folder"),
      opt::real("heartbeat_timeout", 60,
                "seconds without a heartbeat after which a `varbo worker`'s pending trial is abandoned (0 = never; "
                "else at least 0.2: a worker beats every timeout/4, at most every 0.05 s)")
          .at_least(0)
          .at_most(1e8),
      opt::node("parameters", "",
                "typed parameters for tasks that take a domain (external): a list of {name, type: real|int|"
                "categorical|fixed, low, high, log, choices, value} (docs/search_space.md)"),
      opt::node("constraints", "",
                "linear inequalities in user units over real/int parameters, e.g. [\"t1 + t2 + t3 <= 5.5\"]; "
                "every suggestion satisfies them (docs/search_space.md)"),
      opt::integer("stop_after_failures", 10,
                   "`varbo run` and `varbo worker` stop (exit 2, every trial recorded; continue with --resume) after "
                   "this many failed trials in a row, e.g. a robot unplugged or an E-stop pressed (0 = never)")
          .at_least(0),
      opt::boolean("retry_abandoned", false,
                   "hand an abandoned trial's θ out again as it is (phase 'retry') instead of letting the algorithm "
                   "suggest anew"),
  };
  return specs;
}

std::vector<std::string> plugin_paths_of(const ConfigNode& root) {
  std::vector<std::string> out;
  if (!root.is_map() || !root.has("plugin_path")) return out;
  ConfigNode p = root.child("plugin_path");
  std::error_code abs_ec;
  const std::filesystem::path base = std::filesystem::absolute(root.file(), abs_ec).parent_path();
  const std::string expected =
      "expected a plugin file (libvarbo_NAME.so) or a folder of them, absolute or relative to the study file, "
      "or a list of these";
  auto add = [&](const ConfigNode& n) {
    if (!n.is_scalar() || n.scalar().empty()) n.fail(expected);
    std::filesystem::path q(n.scalar());
    const std::filesystem::path full = q.is_absolute() ? q : base / q;
    // A path that names nothing used to be skipped silently, and the study then ran without its plugin.
    std::error_code ec;
    const auto st = std::filesystem::status(full, ec);
    if (ec || !std::filesystem::exists(st)) {
      const std::string why = ec && ec != std::errc::no_such_file_or_directory ? ec.message() : "does not exist";
      // printable(): a NUL in the path ("a\u0000b") cut the message short there; escapes went to the terminal raw.
      n.fail(fmt::format("plugin path '{}'{} {}; {}", printable(n.scalar()),
                         q.is_absolute() ? "" : " (" + printable(full.string()) + ")", why, expected));
    }
    out.push_back(full.string());
  };
  if (p.is_sequence()) {
    for (std::size_t i = 0; i < p.size(); ++i) add(p.item(i));
  } else if (p.defined()) {
    add(p);
  }
  return out;
}

YAML::Node StudyConfig::resolved() const {
  YAML::Node out(YAML::NodeType::Map);
  out["task"] = task.resolved();
  out["algorithm"] = algorithm.resolved();
  // Numbers as text in the "C" locale (yaml_scalar): yaml-cpp's own conversion follows the host's C++ locale.
  out["budget"] = yaml_scalar(budget);
  out["seed"] = yaml_scalar(seed);
  out["threads"] = yaml_scalar(threads);
  out["output"] = output;
  out["heartbeat_timeout"] = yaml_scalar(heartbeat_timeout);
  out["retry_abandoned"] = retry_abandoned;
  out["stop_after_failures"] = yaml_scalar(stop_after_failures);
  if (initial_point) {
    YAML::Node v(YAML::NodeType::Sequence);
    for (Index i = 0; i < initial_point->size(); ++i) v.push_back(yaml_scalar((*initial_point)[i]));
    out["initial_point"] = v;
  }
  if (parameters) out["parameters"] = YAML::Clone(source.child("parameters").yaml());
  if (constraints.defined()) out["constraints"] = YAML::Clone(constraints.yaml());
  // Kept with the stored configuration, so a resumed run's folder still carries it: `--resume` rebuilt the study
  // from the store and dropped it from config.resolved.yaml and summary.json (red team, session 31). Not part of the
  // study's identity (study_identity): a note edited between sessions is the same study.
  if (const ConfigNode d = source.child("description"); d.defined() && d.is_scalar() && !d.scalar().empty())
    out["description"] = d.scalar();
  return out;
}

namespace {

/// The components an algorithm composes (its component-valued options) must meet each other's capability
/// tags (docs/plugins.md), e.g. a `confidence` region needs an acquisition optimizer that honours constraints:
/// `ceres_lbfgs` there would ignore the region. Checked here so the error comes before anything runs.
void check_capabilities(const ResolvedComponent& algorithm, const Registry& registry) {
  struct Part {
    std::string key;
    const ResolvedComponent* rc;
  };
  std::vector<Part> parts;
  for (const auto& o : algorithm.info->options)
    if (o.type == OptionType::Component && algorithm.options.is_set(o.name))
      parts.push_back({"algorithm." + o.name, &algorithm.options.component(o.name)});
  for (const auto& p : parts) {
    for (const auto& tag : p.rc->info->needs) {
      bool met = false;
      for (const auto& q : parts)
        met = met || (&q != &p && std::find(q.rc->info->provides.begin(), q.rc->info->provides.end(), tag) !=
                                      q.rc->info->provides.end());
      if (met) continue;
      // Name the keys of this algorithm whose kind could provide the tag, and the components that do.
      std::vector<std::string> providers, keys;
      for (const ComponentInfo* c : registry.all())
        if (std::find(c->provides.begin(), c->provides.end(), tag) != c->provides.end()) {
          providers.push_back(c->name);
          for (const auto& q : parts)
            if (q.rc->info->kind == c->kind && &q != &p) {
              const std::string k = fmt::format("'{}' ({})", q.key, q.rc->info->name);
              if (std::find(keys.begin(), keys.end(), k) == keys.end()) keys.push_back(k);
            }
        }
      const std::string head = fmt::format("{}: key '{}': {} '{}' needs '{}'", algorithm.options.node(p.key.substr(10)).where(),
                                           p.key, kind_name(p.rc->info->kind), p.rc->info->name, tag);
      if (!keys.empty())
        throw ConfigError(fmt::format("{}, which {} does not provide; use one of: {}", head, join(keys, " or "),
                                      join(providers)));
      throw ConfigError(fmt::format("{}, which no other component of algorithm '{}' provides{}", head,
                                    algorithm.info->name,
                                    providers.empty() ? std::string(" (it is meant for another use, e.g. a fit_optimizer)")
                                                      : "; components that do: " + join(providers)));
    }
  }
}

}  // namespace

StudyConfig parse_study(const ConfigNode& root, const Registry& registry) {
  if (!root.is_map()) root.fail("expected a map of study settings (task:, algorithm:, budget:, ...)");
  Options o = validate_options(root, study_options(), "the study", &registry, {});
  StudyConfig s;
  s.source = root;
  s.task = o.component("task");
  s.algorithm = o.component("algorithm");
  check_capabilities(s.algorithm, registry);
  s.budget = o.integer("budget");
  s.seed = static_cast<std::uint64_t>(o.integer("seed"));
  s.threads = static_cast<int>(o.integer("threads"));
  s.heartbeat_timeout = o.real("heartbeat_timeout");
  // Below 0.2 s every worker looked silent to the others (its beats come at most every 0.05 s): with two workers
  // every trial was abandoned and ran again (red team, session 29). Above 1e8 s the beat schedule overflowed and
  // a worker spun, writing its heartbeat in a loop, and never exited.
  if (s.heartbeat_timeout > 0 && s.heartbeat_timeout < 0.2)
    o.node("heartbeat_timeout")
        .fail(fmt::format("{} s is shorter than a worker's heartbeat can keep up with: give 0 (never abandon) or at "
                          "least 0.2",
                          s.heartbeat_timeout));
  s.retry_abandoned = o.boolean("retry_abandoned");
  s.stop_after_failures = static_cast<Index>(o.integer("stop_after_failures"));
  s.output = o.is_set("output") ? o.str("output") : std::string();
  if (o.given("output") && s.output.find_first_not_of(" \t") == std::string::npos)
    o.node("output").fail("an empty folder name; expected a run folder such as runs/gait (leave the key out for "
                          "runs/<config file name>)");
  // `~/runs/gait` as a shell reads it: it made a folder named '~' in the current one, inviting `rm -rf ~`
  // (red team, session 30). `~user/` is left to the shell (say it without quotes on the command line).
  if (s.output == "~" || s.output.rfind("~/", 0) == 0) {
    const char* home = std::getenv("HOME");
    if (!home || !*home)
      o.node("output").fail(fmt::format("'{}' starts with ~ but HOME is not set; give the folder's full path",
                                        s.output));
    s.output = std::string(home) + s.output.substr(1);
  }
  if (s.output.empty()) {
    const std::string stem = std::filesystem::path(root.file()).stem().string();
    s.output = "runs/" + (stem.empty() ? std::string("study") : stem);
  }
  if (o.is_set("initial_point")) {
    auto v = o.reals("initial_point");
    s.initial_point = Eigen::Map<const Vec>(v.data(), static_cast<Index>(v.size()));
  }
  if (o.is_set("parameters")) s.parameters = std::make_shared<const SearchSpace>(parse_search_space(o.node("parameters")));
  if (o.is_set("constraints")) s.constraints = o.node("constraints");
  return s;
}

StudyConfig study_detail::parse_stored_study(const ConfigNode& root, const Registry& registry,
                                             const std::string& store_path) {
  try {
    return parse_study(root, registry);
  } catch (const UnknownComponentError& e) {
    throw UnknownComponentError(fmt::format(
        "{}; the study {} names a component of a plugin not loaded here: if a third-party plugin provides it "
        "(loaded by Python's load_plugin, VARBO_PLUGIN_PATH or a C++ host when the study was created), give its file "
        "or folder in VARBO_PLUGIN_PATH",
        e.what(), store_path));
  } catch (const ConfigError& e) {
    // The stored configuration was valid when the study was created: a key refused now is a plugin that changed
    // since (an option removed or renamed), and `status` and `export` of the study's trials said only "unknown key"
    // (red team, session 46).
    throw ConfigError(fmt::format(
        "{}; the study {} was created with this configuration, so a component it names (or varbo) has changed since (a plugin "
        "rebuilt without that option, or another version of it loaded): load the plugin version the study was "
        "created with to read or continue it",
        e.what(), store_path));
  }
}

}  // namespace varbo

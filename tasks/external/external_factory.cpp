#include "external_factory.hpp"

#include <fmt/format.h>

#include <filesystem>
#include <mutex>
#include <set>

#include "external_task.hpp"
#include "varbo/log.hpp"
#include "varbo/option_set.hpp"

namespace varbo::tasks {

namespace {
// The box, names and dimension come from several options that must agree: they are read by hand below.
const OptionSet<ExternalTaskSettings>& external_option_set() {
  using S = ExternalTaskSettings;
  static const OptionSet<S> set{
      opt::string("command", &S::command, "shell command evaluating one θ (run with /bin/sh -c)").must(),
      opt::integer("dim", 0, "number of parameters (0: taken from lower/upper or names)").at_least(0).at_most(10000),
      opt::reals("bounds", "", "[lo, hi] for every dimension (default [0, 1] unless lower/upper are given)"),
      opt::reals("lower", "", "lower bound per dimension (with upper)"),
      opt::reals("upper", "", "upper bound per dimension (with lower)"),
      opt::node("names", "", "list of parameter names (default x1, x2, ...)"),
      opt::node("components", "",
                "list of the cost components the command reports in \"components\" (columns of trials.csv, "
                "what `varbo rescore` re-weights); undeclared ones are kept in a study's store only"),
      opt::choice("input", &S::input, {{"json", InputMode::Json}, {"args", InputMode::Args}},
                  "json: {\"theta\": [...], \"names\": [...], \"trial\": k, \"id\": i} on stdin; args: θ as arguments, "
                  "appended to a simple command or where the command says \"$@\" ($1, $2, …; a pipe or a comment "
                  "needs it) (either way VARBO_TRIAL=k and VARBO_TRIAL_ID=i in the environment)"),
      opt::real("timeout", opt::nested(&S::process, &ProcessOptions::timeout_seconds),
                "seconds before the command and every process it started are killed (a failed trial)")
          .above(0),
      opt::real("grace", opt::nested(&S::process, &ProcessOptions::kill_grace_seconds),
                "seconds between SIGTERM and SIGKILL when a trial is stopped (its timeout, Ctrl-C): the time the "
                "command has to bring the hardware to a safe state")
          .at_least(0)
          .at_most(3600),
      opt::string("workdir", opt::nested(&S::process, &ProcessOptions::working_directory),
                  "working directory of the command (default: inherited)"),
      opt::choice("containment", opt::nested(&S::process, &ProcessOptions::containment),
                  {{"auto", Containment::Auto}, {"cgroup", Containment::Cgroup},
                   {"process_group", Containment::ProcessGroup}},
                  "how a trial's processes are held together to be killed: auto: a cgroup v2 per trial where "
                  "varbo may make one (root or a delegated cgroup), else the process group and supervisor; "
                  "cgroup: always a cgroup, a trial fails without one; process_group: never a cgroup"),
  };
  return set;
}
/// A warning about the configuration, once per process: a command builds the task more than once (the study's
/// domain, then the task that runs the trials), and the same line twice reads like two problems.
void warn_once(const std::string& message) {
  static std::mutex mutex;
  static std::set<std::string> said;
  {
    const std::lock_guard<std::mutex> lock(mutex);
    if (!said.insert(message).second) return;
  }
  log_warn("{}", message);
}
}  // namespace

std::vector<OptionSpec> external_options() { return external_option_set().specs(); }

std::unique_ptr<Task> make_external_task(const Options& o) {
  ExternalTaskSettings s = external_option_set().read(o);
  if (s.command.find_first_not_of(" \t\n") == std::string::npos) o.node("command").fail("expected a non-empty command");
  // `sh -c COMMAND` passes the command as one argument, which Linux caps at MAX_ARG_STRLEN (32 pages, 128 KiB)
  // with the terminating NUL: a longer one could never start (execve E2BIG), every trial would fail.
  if (s.command.size() >= 131072)
    o.node("command").fail(fmt::format("the command is {} bytes; a command line holds at most 131071 (the "
                                       "kernel's limit for one argument): put it in a script",
                                       s.command.size()));
  if (s.input == InputMode::Args) {
    std::string what;
    s.args = args_placement(s.command, &what);
    if (s.args == ArgsPlacement::Refused) {
      s.args_refusal = fmt::format(
          "with input: args, θ is appended to the end of the command, but this command has {}: θ would not reach "
          "the trial program (it would go to the last command, or into the comment). Write \"$@\" where θ goes, "
          "e.g. './trial.sh \"$@\" | tee -a sim.log' (θ are the shell's $1, $2, …), or use input: json",
          what);
      // A study created before session 49 still opens (status, export, a worker with a corrected --command): its
      // trials are refused when they would run (ExternalTask::evaluate).
      if (!o.node("command").from_stored_configuration()) o.node("command").fail(s.args_refusal);
      warn_once(fmt::format("{}: key '{}': {}; this study's trials will not run until a worker runs them with a "
                            "corrected command: varbo worker STUDY --command '…'",
                            o.node("command").where(), o.node("command").path(), s.args_refusal));
    }
  }
  if (o.is_set("components")) s.components = cost_component_names(o.node("components"));
  // A missing working directory fails every trial ("cannot change to the working directory"). Only a warning:
  // the task is also built to read a study (status, export, suggest on another machine), which must still open.
  if (!s.process.working_directory.empty()) {
    std::error_code ec;
    if (!std::filesystem::is_directory(s.process.working_directory, ec))
      warn_once(fmt::format("{}: key '{}': working directory '{}' does not exist (or is not a folder): every trial "
                            "will fail until it does",
                            o.node("workdir").where(), o.node("workdir").path(), s.process.working_directory));
  }
  // Like a missing workdir: a warning here (the task is also built to read a study elsewhere), a failed trial
  // saying why at each start.
  if (s.process.containment == Containment::Cgroup && !cgroup_unavailable().empty())
    warn_once(fmt::format("{}: key '{}': containment: cgroup, but no cgroup can be made for a trial here ({}): every "
                          "trial will fail; use containment: auto to fall back to the process group",
                          o.node("containment").where(), o.node("containment").path(), cgroup_unavailable()));
  // Keys that define the domain here, for set_search_space to refuse when the study declares `parameters:`.
  for (const char* key : {"dim", "bounds", "lower", "upper", "names"})
    if (o.given(key) && !(std::string(key) == "dim" && o.integer("dim") == 0))  // dim: 0 is the resolved default
      s.domain_keys.push_back(o.node(key));
  if (s.domain_keys.empty()) {
    // No domain of its own: the study's `parameters:` give it one (set_search_space), or the study refuses it.
    s.box = Box{Vec(0), Vec(0)};
    return std::make_unique<ExternalTask>(std::move(s));
  }

  // Every source of the dimension must agree.
  Index dim = static_cast<Index>(o.integer("dim"));
  std::string dim_from = dim > 0 ? "dim" : "";
  auto agree = [&](Index d, const std::string& key) {
    if (dim > 0 && d != dim)
      o.node(key).fail(fmt::format("has {} entries but {} says the dimension is {}", d, dim_from, dim));
    if (dim == 0) {
      dim = d;
      dim_from = key;
    }
  };

  const bool has_lower = o.is_set("lower"), has_upper = o.is_set("upper");
  if (has_lower != has_upper)
    o.node(has_lower ? "lower" : "upper").fail("lower and upper must be given together");
  if (has_lower && o.is_set("bounds")) o.node("bounds").fail("give either bounds or lower/upper, not both");
  std::vector<double> lower, upper;
  if (has_lower) {
    lower = o.reals("lower");
    upper = o.reals("upper");
    if (lower.empty()) o.node("lower").fail("expected at least one value");
    if (lower.size() != upper.size())
      o.node("upper").fail(fmt::format("has {} entries but lower has {}", upper.size(), lower.size()));
    for (std::size_t i = 0; i < lower.size(); ++i)
      if (!(lower[i] < upper[i])) o.node("upper").fail(fmt::format("entry {} is not above lower[{}]", i, i));
    agree(static_cast<Index>(lower.size()), "lower");
  }

  std::vector<std::string> names;
  if (o.is_set("names")) {
    names = distinct_names(o.node("names"), "parameter");
    agree(static_cast<Index>(names.size()), "names");
  }
  if (dim == 0) o.source().fail("cannot tell the number of parameters: give dim, lower/upper or names (or declare the study's `parameters:`)");

  if (has_lower) {
    s.box = Box{Eigen::Map<const Vec>(lower.data(), dim), Eigen::Map<const Vec>(upper.data(), dim)};
  } else {
    double lo = 0, hi = 1;
    if (o.is_set("bounds")) {
      const auto b = o.reals("bounds");
      if (b.size() != 2 || !(b[0] < b[1])) o.node("bounds").fail("expected [lo, hi] with lo < hi");
      lo = b[0];
      hi = b[1];
    }
    s.box = Box{Vec::Constant(dim, lo), Vec::Constant(dim, hi)};
  }
  if (names.empty())
    for (Index i = 0; i < dim; ++i) names.push_back(fmt::format("x{}", i + 1));
  s.names = std::move(names);
  return std::make_unique<ExternalTask>(std::move(s));
}

}  // namespace varbo::tasks

#pragma once
// A task evaluated by a user command: θ goes in as JSON on stdin or as command-line arguments, the cost
// comes back on stdout (see answer_parser.hpp). Any failure (non-zero exit, signal, timeout, bad
// answer) is a failed trial (Evaluation.ok = false) with a message, never an exception or a hang.
#include <atomic>
#include <string>
#include <vector>

#include "args_placement.hpp"
#include "subprocess.hpp"
#include "varbo/config.hpp"
#include "varbo/search_space.hpp"
#include "varbo/task.hpp"

namespace varbo::tasks {

enum class InputMode { Json, Args };

struct ExternalTaskSettings {
  std::string command;            ///< run as /bin/sh -c command
  Box box;                        ///< user units
  std::vector<std::string> names; ///< one per dimension
  std::vector<std::string> components;  ///< declared cost components (trials.csv columns), possibly none
  InputMode input = InputMode::Json;
  ArgsPlacement args = ArgsPlacement::Append;  ///< with input: args, where θ goes (args_placement.hpp)
  std::string args_refusal;  ///< why, when args is Refused (a stored study's command: its trials do not run)
  ProcessOptions process;         ///< timeout, working directory
  SharedSpace space;              ///< the study's typed parameters (then "params" is sent too), or null
  std::vector<ConfigNode> domain_keys;  ///< dim, bounds, lower, upper, names as given (to refuse `parameters:`)
};

class ExternalTask : public Task, public SpaceAware, public TrialAware {
 public:
  explicit ExternalTask(ExternalTaskSettings settings);
  Domain domain() const override;
  SharedSpace search_space() const override { return s_.space; }
  /// The study's `parameters:`: they define the names and the domain (ConfigError at a key that also does).
  void set_search_space(SharedSpace space) override;
  Evaluation evaluate(const Vec& theta, Rng& rng) override;
  std::vector<std::string> component_names() const override { return s_.components; }
  /// The runner's trial row and study id for the next evaluate(): sent as "trial" and "id", and in the
  /// environment as VARBO_TRIAL and VARBO_TRIAL_ID. Without it (the task used alone) "trial" counts this
  /// object's evaluations from 0 and no id is sent.
  void set_next_trial(long trial, long id) override;

  /// What is sent: the JSON document {"theta": [...], "names": [...], "trial": k} (with typed parameters also
  /// "params": {"lr": 0.001, "waypoints": 4, "solver": "lqr"}) or the shell text appended to the command
  /// (numbers with 17 significant digits, so θ round-trips exactly; with typed parameters name=value words,
  /// labels for categories).
  std::string json_input(const Vec& theta, long trial, long id = -1) const;
  std::string command_with_args(const Vec& theta) const;
  /// θ as words: numbers with 17 significant digits, or name=value with typed parameters (unquoted: for argv).
  std::vector<std::string> argument_words(const Vec& theta) const;

 private:
  ExternalTaskSettings s_;
  std::atomic<long> next_trial_{0};  ///< the next trial's number (set_next_trial, else a count from 0)
  std::atomic<long> next_id_{-1};    ///< the next trial's study id, -1 when not told
};

}  // namespace varbo::tasks

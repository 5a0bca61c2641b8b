#pragma once
// A task evaluated by a user command: θ goes in as JSON on stdin or as command-line arguments, the cost
// comes back on stdout (see answer_parser.hpp). Any failure (non-zero exit, signal, timeout, bad
// answer) is a failed trial (Evaluation.ok = false) with a message, never an exception or a hang.
#include <atomic>
#include <string>
#include <vector>

#include "subprocess.hpp"
#include "varbo/task.hpp"

namespace varbo::tasks {

enum class InputMode { Json, Args };

struct ExternalTaskSettings {
  std::string command;            ///< run as /bin/sh -c command
  Box box;                        ///< user units
  std::vector<std::string> names; ///< one per dimension
  InputMode input = InputMode::Json;
  ProcessOptions process;         ///< timeout, working directory
};

class ExternalTask : public Task {
 public:
  explicit ExternalTask(ExternalTaskSettings settings);
  Domain domain() const override;
  Evaluation evaluate(const Vec& theta, Rng& rng) override;

  /// What is sent: the JSON document {"theta": [...], "names": [...], "trial": k} or the shell text
  /// appended to the command (numbers with 17 significant digits, so θ round-trips exactly).
  std::string json_input(const Vec& theta, long trial) const;
  std::string command_with_args(const Vec& theta) const;

 private:
  ExternalTaskSettings s_;
  std::atomic<long> next_trial_{0};  ///< 0-based count of evaluations of this task object
};

}  // namespace varbo::tasks

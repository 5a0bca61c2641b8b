#pragma once
// Where θ goes in the command line with `input: args` (README.md of this folder).
//
// θ used to be appended to the command text. That is right for one simple command (`./trial.sh --sim`) and wrong
// for anything else: `./trial.sh | tee -a sim.log` handed θ to tee, `./trial.sh  # gains` to the comment, and the
// trial program ran at its built-in defaults while its cost was recorded against the suggested θ (red team,
// session 49). So: a command that says where θ goes ("$@", $1, …) gets θ as the shell's positional parameters; a
// simple command gets θ appended as before; any other command (a pipe, a list, a comment, a subshell) is refused
// with the way to say it.
#include <string>

namespace varbo::tasks {

enum class ArgsPlacement {
  Append,      ///< one simple command: θ appended as words
  Positional,  ///< the command names the positional parameters ($@, $*, $1 … $9, ${…}): θ are $1 … $d
  Refused,     ///< an operator or comment after which appended words would not reach the command
};

/// Reads `command` as /bin/sh would (quotes, backslashes, $( … ) and `…` skipped as words) and says where θ
/// goes; for Refused, `what` names the construct ("a pipe '|'", "a comment '#'", …).
ArgsPlacement args_placement(const std::string& command, std::string* what = nullptr);

}  // namespace varbo::tasks

#pragma once
// Reads an external command's answer from its stdout: a plain number on the last non-empty line, or
// a JSON object {"cost": x, "components": {"name": v, ...}} (possibly pretty-printed over several
// lines, possibly after log lines). {"error": "..."} lets a command report a failed trial itself.
#include <optional>
#include <string>

#include "varbo/task.hpp"

namespace varbo::tasks {

struct Answer {
  double cost = 0;
  Components components;
};

/// The answer, or nullopt with `why` saying what was wrong (empty output, not a number, NaN, ...).
std::optional<Answer> parse_answer(const std::string& stdout_text, std::string& why);

/// The last non-empty line (trimmed), for error messages.
std::string last_nonempty_line(const std::string& text);

}  // namespace varbo::tasks

#include "external_task.hpp"

#include <fmt/format.h>

#include <filesystem>

#include <nlohmann/json.hpp>
#include <stdexcept>

#include "answer_parser.hpp"
#include "varbo/errors.hpp"
#include "varbo/interrupt.hpp"
#include "varbo/text.hpp"

namespace varbo::tasks {

namespace {
// The end of stderr, on one line, for messages.
std::string tail(const std::string& text, std::size_t n) {
  std::string t = text.size() > n ? "..." + text.substr(text.size() - n) : text;
  for (char& c : t)
    if (c == '\n' || c == '\r') c = ' ';
  while (!t.empty() && t.back() == ' ') t.pop_back();
  return t;
}
}  // namespace

ExternalTask::ExternalTask(ExternalTaskSettings settings) : s_(std::move(settings)) {
  if (s_.command.empty()) throw std::invalid_argument("external task: empty command");
  if (static_cast<Index>(s_.names.size()) != s_.box.dim())
    throw std::invalid_argument("external task: one name per dimension is needed");
}

Domain ExternalTask::domain() const { return Domain{s_.box, s_.names}; }

void ExternalTask::set_search_space(SharedSpace space) {
  // A second definition of the domain could only disagree with the parameters.
  if (!s_.domain_keys.empty())
    s_.domain_keys.front().fail("the study declares `parameters:`, which define the names and the domain; remove this key");
  s_.space = std::move(space);
  s_.box = s_.space->user_box();
  s_.names = s_.space->names();
}

std::string ExternalTask::json_input(const Vec& theta, long trial, long id) const {
  nlohmann::json j;
  if (s_.space) j["params"] = nlohmann::json::parse(s_.space->params(theta).to_json());
  j["theta"] = std::vector<double>(theta.data(), theta.data() + theta.size());
  j["names"] = s_.names;
  j["trial"] = trial;
  if (id >= 0) j["id"] = id;
  return j.dump() + "\n";
}

void ExternalTask::set_next_trial(long trial, long id) {
  next_trial_ = trial;
  next_id_ = id;
}

std::vector<std::string> ExternalTask::argument_words(const Vec& theta) const {
  std::vector<std::string> words;
  for (Index i = 0; i < theta.size(); ++i)
    words.push_back(s_.space ? fmt::format("{}={}", s_.names[static_cast<std::size_t>(i)],
                                           s_.space->format_value(static_cast<std::size_t>(i), theta[i]))
                             : fmt::format("{:.17g}", theta[i]));
  return words;
}

std::string ExternalTask::command_with_args(const Vec& theta) const {
  // Without its trailing line breaks (a YAML block scalar ends with one: θ became a second command).
  std::string c = s_.command.substr(0, s_.command.find_last_not_of(" \t\r\n") + 1);
  if (s_.space) {
    // name=value words; a label is quoted for the shell.
    for (Index i = 0; i < theta.size(); ++i) {
      std::string v = s_.space->format_value(static_cast<std::size_t>(i), theta[i]);
      std::string quoted = "'";
      for (const char ch : v) quoted += ch == '\'' ? std::string("'\\''") : std::string(1, ch);
      c += fmt::format(" {}={}'", s_.names[static_cast<std::size_t>(i)], quoted);
    }
    return c;
  }
  for (Index i = 0; i < theta.size(); ++i) c += fmt::format(" {:.17g}", theta[i]);
  return c;
}

Evaluation ExternalTask::evaluate(const Vec& theta, Rng& /*rng: the command owns its randomness*/) {
  Evaluation e;
  if (theta.size() != s_.box.dim()) {
    e.ok = false;
    e.error = fmt::format("external task: expected {} parameters, got {}", s_.box.dim(), theta.size());
    return e;
  }
  if (s_.input == InputMode::Args && s_.args == ArgsPlacement::Refused)  // a stored study's command (external_factory.cpp)
    throw TaskSetupError(s_.args_refusal + "; nothing was evaluated");
  const long trial = next_trial_++;
  const long id = next_id_.exchange(-1);
  const bool json = s_.input == InputMode::Json;
  ProcessOptions process = s_.process;
  process.environment.push_back(fmt::format("VARBO_TRIAL={}", trial));
  if (id >= 0) process.environment.push_back(fmt::format("VARBO_TRIAL_ID={}", id));
  const bool positional = !json && s_.args == ArgsPlacement::Positional;
  if (positional) process.arguments = argument_words(theta);
  const ProcessResult r = run_shell(json || positional ? s_.command : command_with_args(theta),
                                    json ? json_input(theta, trial, id) : "", process);

  // The message goes to trials.csv, log.txt, the study store and the terminal: bounded (a 50 MB line is
  // quoted by its ends) and printable (binary output is escaped), whatever the command wrote.
  auto fail = [&](const std::string& what) {
    e.ok = false;
    std::string msg = fmt::format("external command failed ({}): {}; last stdout line: '{}'", r.status_text(), what,
                                  tail(abbreviate(last_nonempty_line(r.out), 100), 300));
    if (r.out_dropped > 0)
      msg += fmt::format(" (stdout was {} bytes, only its last {} were read into memory)", r.out_dropped + r.out.size(),
                         r.out.size());
    msg += fmt::format("; stderr: '{}'", tail(r.err, 400));
    e.error = abbreviate(printable(msg), 2048);
    return e;
  };
  // Stopped because varbo was asked to stop: no result of θ. Said by throwing Interrupted (task.hpp), so that the
  // runner abandons the trial; a trial that failed on its own (a timeout) while the signal came stays failed.
  if (r.interrupted) throw Interrupted(r.interrupted);
  if (!r.started)  // no θ was evaluated: a failed trial would spend budget and teach the failure model a lie
    throw TaskSetupError(abbreviate(
        printable(fmt::format("external task: the command could not be started ({}); nothing was evaluated. Check "
                              "the machine's limits (`ulimit -u` processes, `ulimit -n` open files), memory and "
                              "the task's containment, then continue the study",
                              r.error)),
        2048));
  if (r.timed_out)
    // "no answer" beside a last stdout line holding one read as a contradiction (red team, session 46): an answer
    // counts once the command has exited.
    return fail(fmt::format("no answer within the timeout of {} s{}", s_.process.timeout_seconds,
                            last_nonempty_line(r.out).empty()
                                ? std::string()
                                : " (it printed a line, but had not exited: an answer counts once the command "
                                  "exits)"));
  if (r.output_held)
    return fail("its stdout was kept open by a process it started outside its process tree; the answer may be "
                "incomplete");
  if (!r.exited && r.signal == 0)  // no verdict: the supervisor was killed (subprocess.cpp swept the tree)
    return fail(r.in_cgroup ? "its supervisor was killed (by the command?); every process in the trial's cgroup and "
                              "every process carrying the trial's token was killed"
                            : "its supervisor was killed (by the command?); every process carrying the trial's token "
                              "was killed");
  if (!r.exited) return fail("terminated by a signal");
  // 126/127 is the shell's "cannot run" only for a command that ran nothing: one that printed its cost and then
  // failed to find a tool it calls last (an upload) ran on the rig, and the run stopped with the trial abandoned,
  // the cost lost and θ due to run again on --resume (audit, session 47). Output on stdout: a failed trial.
  if ((r.exit_status == 126 || r.exit_status == 127) && !last_nonempty_line(r.out).empty())
    return fail(fmt::format("it printed output, then a command it ran was {}",
                            r.exit_status == 127 ? "not found" : "not executable"));
  if (r.exit_status == 126 || r.exit_status == 127) {
    std::error_code ec;
    const std::string here = s_.process.working_directory.empty()
                                 ? std::filesystem::current_path(ec).string()
                                 : s_.process.working_directory;
    throw TaskSetupError(abbreviate(
        printable(fmt::format(
            "external task: the command could not be run (exit status {}: {}; stderr: '{}') in the working directory "
            "{}; a relative command or path is looked up there: start varbo in the folder it expects, or give the "
            "task `workdir:` or an absolute command",
            r.exit_status, r.exit_status == 127 ? "not found, or could not be started" : "not executable",
            tail(r.err, 400), here)),
        2048));
  }
  if (r.exit_status != 0) return fail("non-zero exit");
  std::string why;
  const auto answer = parse_answer(r.out, why);
  if (!answer) return fail(why);
  e.cost = answer->cost;
  e.components = answer->components;
  return e;
}

}  // namespace varbo::tasks

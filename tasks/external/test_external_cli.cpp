// `varbo run` with external commands that misbehave, as a user would see it (issue 11, items 2 and 6):
//  - SIGTERM, SIGINT or SIGHUP during a long trial: varbo exits at once with 128 + signal, the command's whole
//    tree (a child in its own session included) is gone, the trial is recorded abandoned, and --resume
//    finishes the run; after SIGKILL the tree is gone too;
//  - a child in a new session holding stdout, with threads 1 and 2: the trial ends at the command's exit or at
//    the timeout, and nothing of it survives;
//  - a 50 MB answer line and a binary answer: short messages, trials.csv valid UTF-8 with one line per trial.
#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fmt/format.h>
#include <fstream>
#include <sstream>
#include <thread>

#include "study_helpers.hpp"
#include "varbo/csv.hpp"
#include "varbo/interrupt.hpp"
#include "varbo/store.hpp"
#include "process_probe.hpp"
#include "trial_cgroup.hpp"
#include "varbo_test.hpp"

using namespace varbo;
using test::alive;
using test::pids_in;

namespace {

using Clock = std::chrono::steady_clock;

pid_t spawn(const std::vector<std::string>& args, const std::string& log) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
    if (fd >= 0) {
      ::dup2(fd, 1);
      ::dup2(fd, 2);
      ::close(fd);
    }
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  return pid;
}

// The exit code; 1000 + signal when killed by a signal (not a clean exit); -1 if still running after `seconds`.
int wait_exit(pid_t pid, double seconds) {
  const auto deadline = Clock::now() + std::chrono::duration<double>(seconds);
  int status = 0;
  while (::waitpid(pid, &status, WNOHANG) != pid) {
    if (Clock::now() > deadline) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, &status, 0);
      return -1;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : 1000 + WTERMSIG(status);
}

int run_varbo(const std::vector<std::string>& args, const std::string& log, double seconds = 60) {
  std::vector<std::string> all = {VARBO_EXE};
  all.insert(all.end(), args.begin(), args.end());
  return wait_exit(spawn(all, log), seconds);
}

bool wait_for_lines(const std::string& file, std::size_t n, double seconds) {
  const auto deadline = Clock::now() + std::chrono::duration<double>(seconds);
  while (pids_in(file).size() < n) {
    if (Clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return true;
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

bool valid_utf8(const std::string& file) {  // an independent decoder
  return std::system(("iconv -f UTF-8 -t UTF-8 '" + file + "' >/dev/null 2>&1").c_str()) == 0;
}

std::size_t lines_of(const std::string& file) {
  const std::string s = read_file(file);
  return static_cast<std::size_t>(std::count(s.begin(), s.end(), '\n'));
}

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// The trial cgroups (trial_cgroup.hpp) of the varbo process `pid` that exist now.
std::vector<std::string> trial_cgroups_of(pid_t pid) {
  std::vector<std::string> out;
  const std::string& home = tasks::cgroup_home().dir;
  if (home.empty()) return out;
  const std::string prefix = fmt::format("{}{}-", tasks::kTrialCgroupPrefix, static_cast<long>(pid));
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(home, ec))
    if (e.path().filename().string().rfind(prefix, 0) == 0) out.push_back(e.path().string());
  return out;
}

}  // namespace

TEST_CASE("varbo run: a stop signal kills the running command's tree, abandons its trial, --resume finishes") {
  for (const int sig : {SIGTERM, SIGINT, SIGHUP, SIGQUIT, SIGKILL}) {  // SIGQUIT (Ctrl-\): session 47
    CAPTURE(sig);
    const std::string dir = test::temp_folder(fmt::format("ext_cli_signal_{}", sig));
    // While the file `slow` exists, a trial is a shell and a child in its own session that sleep.
    std::ofstream(dir + "/trial.sh") << "if [ -e " << dir << "/slow ]; then\n"
                                     << "  echo $$ >> " << dir << "/pids\n"
                                     << "  setsid sh -c 'echo $$ >> " << dir << "/pids; exec sleep 30' &\n"
                                     << "  sleep 30\n"
                                     << "fi\n"
                                     << "echo 1.5\n";
    std::ofstream(dir + "/study.yaml") << "task: {type: external, command: 'sh " << dir
                                       << "/trial.sh', dim: 1, bounds: [0, 1], timeout: 60}\n"
                                       << "algorithm: {type: random}\nbudget: 3\nseed: 4\n";
    std::ofstream(dir + "/slow");
    const std::string out = dir + "/run", log = dir + "/log.txt";
    const pid_t varbo = spawn({VARBO_EXE, "run", dir + "/study.yaml", "-o", out, "--no-progress"}, log);
    REQUIRE(wait_for_lines(dir + "/pids", 2, 20));
    const auto pids = pids_in(dir + "/pids");
    const auto t0 = Clock::now();
    ::kill(varbo, sig);
    const int code = wait_exit(varbo, 10);
    const double stop_seconds = seconds_since(t0);
    if (sig == SIGKILL) {
      // No chance to clean up: the supervisor, told by the kernel (PR_SET_PDEATHSIG), kills the tree; the
      // trial stays pending until --resume finds its process gone.
      CHECK(code == 1000 + SIGKILL);
      const auto deadline = Clock::now() + std::chrono::seconds(3);
      while ((alive(pids[0]) || alive(pids[1])) && Clock::now() < deadline)
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    } else {
      CHECK(code == 128 + sig);  // exited (cleanly, with the shell's code for that signal), not killed by it
      CHECK(stop_seconds < 2.0);  // the kill grace is 0.2 s
      CHECK(read_file(log).find("--resume") != std::string::npos);
    }
    for (pid_t p : pids) CHECK_FALSE(alive(p));
    // The trial's cgroup is gone too (after SIGKILL the supervisor removes it once it has emptied it).
    const auto cg_deadline = Clock::now() + std::chrono::seconds(3);
    while (!trial_cgroups_of(varbo).empty() && Clock::now() < cg_deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    CHECK(trial_cgroups_of(varbo).empty());
    {
      auto store = open_sqlite_store(out + "/study.db");
      const auto trials = store->trials();
      REQUIRE(trials.size() == 1);
      if (sig == SIGKILL) {
        CHECK(trials[0].state == TrialState::Pending);
      } else {
        CHECK(trials[0].state == TrialState::Abandoned);
        CHECK(trials[0].error == "interrupted by " + signal_name(sig));
      }
    }
    CHECK(lines_of(out + "/trials.csv") == 1);  // the header: nothing finished

    std::filesystem::remove(dir + "/slow");
    CHECK(run_varbo({"run", "--resume", out, "--no-progress"}, log) == 0);
    const auto rows = test::read_rows(out + "/trials.csv");
    REQUIRE(rows.size() == 4);
    for (std::size_t i = 1; i < rows.size(); ++i) {
      CHECK(rows[i][test::column_of(rows[0], "ok")] == "1");
      CHECK(rows[i][test::column_of(rows[0], "cost")] == "1.5");
    }
  }
}

TEST_CASE("varbo run, threads 1 and 2: a child in a new session holding stdout does not hold the trial") {
  for (const int threads : {1, 2}) {
    CAPTURE(threads);
    const std::string dir = test::temp_folder(fmt::format("ext_cli_setsid_{}", threads));
    // Trial 0 answers and exits, trial 1 keeps running: both leave a child in a new session on stdout.
    std::ofstream(dir + "/trial.sh") << "read -r input\n"
                                     << "setsid sh -c 'echo $$ >> " << dir << "/pids; exec sleep 20' &\n"
                                     << "while [ ! -s " << dir << "/pids ]; do sleep 0.01; done\n"
                                     << "echo 6.5\n"
                                     << "case \"$input\" in *'\"trial\":1'*) sleep 30;; esac\n";
    std::ofstream(dir + "/study.yaml") << "task: {type: external, command: 'sh " << dir
                                       << "/trial.sh', dim: 1, bounds: [0, 1], timeout: 2}\n"
                                       << "algorithm: {type: random}\nbudget: 2\nseed: 4\n";
    const auto t0 = Clock::now();
    CHECK(run_varbo({"run", dir + "/study.yaml", "-o", dir + "/run", "--no-progress", "--threads",
                     std::to_string(threads)},
                    dir + "/log.txt", 30) == 0);
    CHECK(seconds_since(t0) < 8.0);  // 2 s timeout + start-up; was 20 s per trial
    const auto rows = test::read_rows(dir + "/run/trials.csv");
    REQUIRE(rows.size() == 3);
    const int ok = test::column_of(rows[0], "ok"), cost = test::column_of(rows[0], "cost");
    const int secs = test::column_of(rows[0], "evaluation_seconds");
    CHECK(rows[1][ok] == "1");
    CHECK(rows[1][cost] == "6.5");
    CHECK(std::stod(rows[1][secs]) < 1.5);
    CHECK(rows[2][ok] == "0");
    CHECK(read_file(dir + "/run/trials.csv").find("timed out") != std::string::npos);
    CHECK(std::stod(rows[2][secs]) < 4.0);
    const auto pids = pids_in(dir + "/pids");
    CHECK(pids.size() == 2);
    for (pid_t p : pids) CHECK_FALSE(alive(p));
  }
}

TEST_CASE("varbo run: a 50 MB answer line and a binary answer keep the run folder readable") {
  const std::string dir = test::temp_folder("ext_cli_outputs");
  std::ofstream(dir + "/trial.sh")
      << "read -r input\n"
      << "case \"$input\" in\n"
      << "  *'\"trial\":0'*) head -c 50000000 /dev/zero | tr '\\0' a; echo;;\n"
      << "  *) printf 'bad \\377\\376\\000\\033[31m,\"q\"\\r\\200\\n'; printf 'oops\\0\\377\\n' >&2;;\n"
      << "esac\n";
  std::ofstream(dir + "/study.yaml") << "task: {type: external, command: 'sh " << dir
                                     << "/trial.sh', dim: 1, bounds: [0, 1], timeout: 60}\n"
                                     << "algorithm: {type: random}\nbudget: 2\nseed: 4\n";
  const std::string out = dir + "/run", log = dir + "/stderr.txt";
  REQUIRE(run_varbo({"run", dir + "/study.yaml", "-o", out}, log) == 0);
  const std::string csv = out + "/trials.csv";
  CHECK(valid_utf8(csv));
  CHECK(lines_of(csv) == 3);  // header and one line per trial: no raw newline from the output
  CHECK(std::filesystem::file_size(csv) < 16384);
  CHECK(read_file(csv).find("bytes omitted") != std::string::npos);
  CHECK(read_file(csv).find("\\xFF\\xFE") != std::string::npos);
  CHECK(valid_utf8(out + "/log.txt"));
  CHECK(std::filesystem::file_size(out + "/log.txt") < 32768);
  CHECK(valid_utf8(log));
  CHECK(std::filesystem::file_size(log) < 32768);
  CHECK(std::filesystem::file_size(out + "/study.db") < (1u << 20));
  auto store = open_sqlite_store(out + "/study.db");
  for (const auto& t : store->trials()) {
    CHECK(t.state == TrialState::Failed);
    CHECK(t.error.size() < 8192);
  }
}

TEST_CASE("varbo run: an external task's declared cost components reach trials.csv and varbo rescore") {
  const std::string dir = test::temp_folder("ext_cli_components");
  // cost = tracking + effort, with tracking = (x1 - 0.3)^2 and effort = x2; trial 2 leaves effort out.
  std::ofstream(dir + "/trial.sh")
      << "read -r input\n"
      << "python3 -c \"import json,sys; j=json.loads(sys.argv[1]); x=j['theta']; t=(x[0]-0.3)**2; e=x[1];"
      << " c={'tracking': t} if j['trial']==2 else {'tracking': t, 'effort': e, 'extra': 1};"
      << " print(json.dumps({'cost': t+e, 'components': c}))\" \"$input\"\n";
  auto study = [&](const std::string& components) {
    std::ofstream(dir + "/study.yaml") << "task: {type: external, command: 'sh " << dir
                                       << "/trial.sh', dim: 2, bounds: [0, 1]" << components << "}\n"
                                       << "algorithm: {type: random}\nbudget: 8\nseed: 3\n";
  };
  const std::string log = dir + "/stderr.txt";

  study(", components: [tracking, effort]");
  const std::string out = dir + "/declared";
  REQUIRE(run_varbo({"run", dir + "/study.yaml", "-o", out}, log) == 0);
  const std::string csv = read_file(out + "/trials.csv");
  CHECK(csv.substr(0, csv.find('\n')).find(",ok,tracking,effort,fit_seconds") != std::string::npos);
  CHECK(lines_of(out + "/trials.csv") == 9);
  CHECK(read_file(log).find("undeclared cost component 'extra'") != std::string::npos);  // once, named
  // Re-weighting: effort × 3 changes every selection's cost by 2·effort; 7 of 8 trials carry both components.
  const std::string rescored = dir + "/rescore.txt";
  CHECK(run_varbo({"rescore", out, "--weights", "effort=3", "--kappa", "0"}, rescored) == 0);
  const std::string text = read_file(rescored);
  MESSAGE(text);
  CHECK(text.find("7 successful trials, components tracking, effort") != std::string::npos);
  CHECK(text.find("effort=3 (was 1)") != std::string::npos);
  // The re-scored mean against tracking + 3·effort summed here from trials.csv (printed with 6 digits).
  double sum = 0;
  int n = 0;
  std::istringstream rows(csv);
  std::string row;
  std::getline(rows, row);
  const std::vector<std::string> header = split_csv_line(row);
  const auto col = [&](const char* name) { return std::find(header.begin(), header.end(), name) - header.begin(); };
  while (std::getline(rows, row)) {
    const std::vector<std::string> cells = split_csv_line(row);
    if (cells[col("effort")] == "nan") continue;
    sum += std::stod(cells[col("tracking")]) + 3 * std::stod(cells[col("effort")]);
    ++n;
  }
  CHECK(n == 7);
  const std::size_t at = text.find(" mean ");
  REQUIRE(at != std::string::npos);
  CHECK(std::stod(text.substr(at + 6)) == doctest::Approx(sum / n).epsilon(1e-5));

  // Undeclared: the run still works, trials.csv has no component columns, rescore says why.
  study("");
  const std::string plain = dir + "/undeclared";
  REQUIRE(run_varbo({"run", dir + "/study.yaml", "-o", plain}, log) == 0);
  CHECK(read_file(plain + "/trials.csv").find("tracking") == std::string::npos);
  const std::string refused = dir + "/refused.txt";
  CHECK(run_varbo({"rescore", plain}, refused) == 2);
  CHECK(read_file(refused).find("recorded no cost components") != std::string::npos);

  // Bad declarations: the file, line and column, and what is expected.
  int k = 0;
  for (const char* bad : {", components: [a, a]", ", components: 5", ", components: []"}) {
    study(bad);
    const std::string errors = fmt::format("{}/bad{}.txt", dir, ++k);
    CHECK(run_varbo({"run", dir + "/study.yaml", "-o", dir + "/bad"}, errors) == 2);
    const std::string err = read_file(errors);
    MESSAGE(err);
    CHECK(err.find("study.yaml:1:") != std::string::npos);
    CHECK((err.find("duplicate name 'a'") != std::string::npos ||
           err.find("expected a non-empty list of cost component names") != std::string::npos));
    CHECK(!std::filesystem::exists(dir + "/bad/trials.csv"));
  }
}

TEST_CASE("varbo run: empty trial cgroups of a varbo that is gone are removed, a populated one is left") {
  if (!tasks::cgroup_unavailable().empty()) {
    MESSAGE("cgroup containment is not available here, skipped: " << tasks::cgroup_unavailable());
    return;
  }
  const std::string& home = tasks::cgroup_home().dir;
  // A pid that is gone: a child that exited and was reaped.
  const pid_t dead = ::fork();
  if (dead == 0) ::_exit(0);
  REQUIRE(dead > 0);
  ::waitpid(dead, nullptr, 0);
  const std::string stale = fmt::format("{}/{}{}-0-0", home, tasks::kTrialCgroupPrefix, static_cast<long>(dead));
  const std::string busy = fmt::format("{}/{}{}-1-0", home, tasks::kTrialCgroupPrefix, static_cast<long>(dead));
  REQUIRE(::mkdir(stale.c_str(), 0755) == 0);
  REQUIRE(::mkdir((stale + "/nested").c_str(), 0755) == 0);  // a nested varbo's, empty too
  REQUIRE(::mkdir(busy.c_str(), 0755) == 0);
  const pid_t sleeper = ::fork();
  if (sleeper == 0) {
    std::ofstream(busy + "/cgroup.procs") << ::getpid() << std::flush;
    ::execl("/bin/sleep", "sleep", "30", static_cast<char*>(nullptr));
    ::_exit(127);
  }
  REQUIRE(sleeper > 0);
  const auto until = Clock::now() + std::chrono::seconds(5);
  while (read_file(busy + "/cgroup.procs").empty() && Clock::now() < until)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  const std::string dir = test::temp_folder("ext_cli_stale_cgroup");
  std::ofstream(dir + "/study.yaml") << "task: {type: external, command: 'echo 1', dim: 1}\n"
                                     << "algorithm: {type: random}\nbudget: 1\nseed: 1\n";
  CHECK(run_varbo({"run", dir + "/study.yaml", "-o", dir + "/run", "--no-progress"}, dir + "/log.txt") == 0);
  CHECK_FALSE(std::filesystem::exists(stale));
  CHECK(std::filesystem::exists(busy));  // its process is not ours to kill
  ::kill(sleeper, SIGKILL);
  ::waitpid(sleeper, nullptr, 0);
  CHECK(::rmdir(busy.c_str()) == 0);
}

TEST_CASE("varbo run: the timeout holds while varbo itself is stopped (Ctrl-Z): the supervisor ends the command") {
  // Red team, session 34: only varbo enforced the deadline; stopped by Ctrl-Z (or by the command, `kill -STOP` on
  // its parent), it let a command with `timeout: 2` run on; the trial ended only when varbo was continued.
  const std::string dir = test::temp_folder("stopped_varbo_" + std::to_string(::getpid()));
  const std::string cfg = dir + "/cfg.yaml", pids = dir + "/pids";
  std::ofstream(cfg) << "task: {type: external, command: 'echo $$ >> " << pids
                     << "; exec sleep 60', dim: 1, timeout: 1, grace: 0.2}\nbudget: 1\nseed: 1\nalgorithm: random\n";
  const pid_t v = spawn({VARBO_EXE, "run", cfg, "-o", dir + "/run", "--no-progress"}, dir + "/run.log");
  REQUIRE(wait_for_lines(pids, 1, 30));
  ::kill(v, SIGSTOP);
  const pid_t command = pids_in(pids)[0];
  const auto t0 = Clock::now();
  while (alive(command) && seconds_since(t0) < 10) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  CHECK_FALSE(alive(command));  // ended by its supervisor at the timeout (+ 0.5 s backstop + grace)
  CHECK(seconds_since(t0) < 5);
  ::kill(v, SIGCONT);
  CHECK(wait_exit(v, 30) == 0);
  const auto trials = open_sqlite_store(dir + "/run/study.db")->trials();
  REQUIRE(trials.size() == 1);
  CHECK(trials[0].state == TrialState::Failed);
  CHECK(trials[0].error.find("timed out after") != std::string::npos);
}

TEST_CASE("varbo run: a trial that timed out stays failed when Ctrl-C comes during its grace") {
  // Red team, session 34: the SIGINT turned it into "abandoned", and --resume ran the θ that hung again.
  const std::string dir = test::temp_folder("grace_interrupt_" + std::to_string(::getpid()));
  const std::string cfg = dir + "/cfg.yaml", pids = dir + "/pids";
  std::ofstream(cfg) << "task: {type: external, command: \"trap '' TERM; echo $$ >> " << pids
                     << "; sleep 30\", dim: 1, timeout: 1, grace: 4}\nbudget: 2\nseed: 1\nalgorithm: random\n";
  const pid_t v = spawn({VARBO_EXE, "run", cfg, "-o", dir + "/run", "--no-progress"}, dir + "/run.log");
  REQUIRE(wait_for_lines(pids, 1, 30));
  std::this_thread::sleep_for(std::chrono::milliseconds(2000));  // past the timeout, inside the grace
  ::kill(v, SIGINT);
  CHECK(wait_exit(v, 30) == 128 + SIGINT);
  const auto trials = open_sqlite_store(dir + "/run/study.db")->trials();
  REQUIRE(trials.size() == 1);
  CHECK(trials[0].state == TrialState::Failed);
  CHECK(trials[0].error.find("no answer within the timeout") != std::string::npos);
}

TEST_CASE("varbo run killed by SIGKILL keeps its run lock until its last trial's command is gone") {
  // Red team, session 34: the lock died with varbo while the command was still in its grace period, and an
  // immediate --resume started the next trial beside it (two commands driving one robot).
  const std::string dir = test::temp_folder("kill_keeps_lock_" + std::to_string(::getpid()));
  const std::string cfg = dir + "/cfg.yaml", pids = dir + "/pids", out = dir + "/run";
  std::ofstream(cfg) << "task: {type: external, command: \"if [ -e " << dir << "/fast ]; then echo 1; else trap '' TERM; "
                     << "echo $$ >> " << pids << "; sleep 30; fi\", dim: 1, timeout: 60, grace: 3}\nbudget: 2\n"
                     << "seed: 1\nalgorithm: random\n";
  const pid_t v = spawn({VARBO_EXE, "run", cfg, "-o", out, "--no-progress"}, dir + "/run.log");
  REQUIRE(wait_for_lines(pids, 1, 30));
  ::kill(v, SIGKILL);
  CHECK(wait_exit(v, 10) == 1000 + SIGKILL);
  const pid_t command = pids_in(pids)[0];
  CHECK(alive(command));  // in its grace period (it ignores SIGTERM)
  CHECK(run_varbo({"run", "--resume", out, "--no-progress"}, dir + "/early.log") == 2);
  const std::string early = read_file(dir + "/early.log");
  CHECK(early.find("in use by another run") != std::string::npos);
  CHECK(early.find("that process has ended") != std::string::npos);
  CHECK(pids_in(pids).size() == 1);  // no second command started
  const auto t0 = Clock::now();
  while (alive(command) && seconds_since(t0) < 15) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  CHECK_FALSE(alive(command));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // the supervisor exits after the tree
  std::ofstream(dir + "/fast") << "";  // the resumed trials answer at once
  CHECK(run_varbo({"run", "--resume", out, "--no-progress"}, dir + "/late.log") == 0);
}

TEST_CASE("varbo run killed by SIGKILL or a second Ctrl-C: the command writes during its grace and is not killed by it") {
  // Audit, session 45: once varbo was gone, nothing read the command's pipes, and the SIGTERM trap that parks the
  // robot died of SIGPIPE at its first "motors off" on stderr (a Python handler got BrokenPipeError). The
  // supervisor now holds the pipes' read ends and drains them after varbo is gone.
  for (const bool twice_ctrl_c : {false, true}) {
    CAPTURE(twice_ctrl_c);
    const std::string dir =
        test::temp_folder(fmt::format("grace_writes_{}_{}", twice_ctrl_c ? "int" : "kill", ::getpid()));
    const std::string cfg = dir + "/cfg.yaml", pids = dir + "/pids", log = dir + "/safe.log";
    std::ofstream(dir + "/safe.sh") << "#!/bin/sh\necho $$ >> " << pids << "\n"
                                    << "trap 'echo parking >> " << log << "; sleep 0.5; echo \"motors off\" >&2; "
                                    << "yes status | head -c 200000; echo parked >> " << log << "; exit 1' TERM\n"
                                    << "sleep 30 & wait\necho 0.5\n";
    ::chmod((dir + "/safe.sh").c_str(), 0755);
    std::ofstream(cfg) << "task: {type: external, command: " << dir << "/safe.sh, dim: 1, timeout: 60, grace: 5}\n"
                       << "budget: 2\nseed: 1\nalgorithm: random\n";
    const pid_t v = spawn({VARBO_EXE, "run", cfg, "-o", dir + "/run", "--no-progress"}, dir + "/run.log");
    REQUIRE(wait_for_lines(pids, 1, 30));
    if (twice_ctrl_c) {
      ::kill(v, SIGINT);
      std::this_thread::sleep_for(std::chrono::milliseconds(200));  // inside the command's grace
      ::kill(v, SIGINT);
      const int code = wait_exit(v, 10);
      CHECK((code == 128 + SIGINT || code == 1000 + SIGINT));  // the second Ctrl-C ends varbo at once
    } else {
      ::kill(v, SIGKILL);
      CHECK(wait_exit(v, 10) == 1000 + SIGKILL);
    }
    const pid_t command = pids_in(pids)[0];
    const auto t0 = Clock::now();
    while (alive(command) && seconds_since(t0) < 15) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    CHECK_FALSE(alive(command));
    // 200 kB written after varbo was gone, more than a pipe holds: drained, neither fatal nor blocking.
    CHECK(read_file(log) == "parking\nparked\n");
  }
}

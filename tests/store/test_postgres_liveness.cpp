// Who is alive on a PostgreSQL study (run_liveness.hpp, store.hpp's note_store_unreachable, the run lock's socket
// kept by the trials' supervisors): found by session 49's red team, each case ran one θ twice on the rig.
//  - A server restart ends the `varbo run`'s lock session while the run lives: a waiting worker took the free lock
//    for a dead run and ran the run's θ again.
//  - SIGKILL of `varbo run` released its lock at once while its command was still stopping: a worker started the
//    same θ beside it.
//  - After an outage longer than heartbeat_timeout, the first worker back judged the others dead by the heartbeats
//    none of them could send, and abandoned their trials.
#include <signal.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <thread>

#include "backends.hpp"
#include "process.hpp"
#include "study_helpers.hpp"
#include "varbo/store.hpp"
#include "varbo/run_lock.hpp"
#include "varbo/study_api.hpp"
#include "varbo_test.hpp"

using namespace varbo;

namespace {

/// A server of the test's own (it is restarted), stopped when the test ends.
struct OwnServer {
  std::string script = test::source_path("tests/store/pg_server.sh");
  std::string state;
  std::string base;
  explicit OwnServer(const std::string& dir) : state(dir + "/server") {
    REQUIRE(std::system((script + " start " + state + " >/dev/null").c_str()) == 0);
    std::getline(std::ifstream(state + "/url"), base);
  }
  ~OwnServer() { (void)std::system((script + " stop " + state).c_str()); }
  /// Down for `seconds`, then up again on the same data.
  void restart(double seconds) const {
    CHECK(std::system((script + " restart " + state + " " + std::to_string(seconds)).c_str()) == 0);
  }
};

Index count_state(const std::string& url, TrialState s) {
  for (int attempt = 0; attempt < 3; ++attempt) {
    try {
      Index n = 0;
      for (const auto& t : open_store(url)->trials()) n += t.state == s ? 1 : 0;
      return n;
    } catch (const InputError&) {  // the server is restarting
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
    }
  }
  return -1;
}

void wait_until(const std::function<bool()>& ready, double seconds) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (!ready() && std::chrono::steady_clock::now() < end) std::this_thread::sleep_for(std::chrono::milliseconds(50));
}

/// No two finished trials of `url` measured the same θ.
void check_distinct_thetas(const std::vector<TrialRecord>& trials) {
  std::set<std::vector<double>> seen;
  for (const auto& t : trials) {
    if (t.state != TrialState::Complete && t.state != TrialState::Failed) continue;
    const std::vector<double> theta(t.theta.data(), t.theta.data() + t.theta.size());
    CAPTURE(t.id);
    CHECK(seen.insert(theta).second);
  }
}

}  // namespace

TEST_CASE("postgresql: a server restart during a `varbo run` trial does not let a worker run that θ again") {
  const std::string dir = test::temp_folder("pg_live_run_restart");
  OwnServer server(dir);
  const std::string url = server.base + "&study=live_run";
  std::ofstream(dir + "/cfg.yaml") << "task: {type: external, command: 'cat > /dev/null; sleep 4; echo 1.5', dim: 2}\n"
                                      "budget: 1\nseed: 3\nheartbeat_timeout: 4\nalgorithm: {type: random}\n";
  REQUIRE(test::run({VARBO_EXE, "study", "create", url, dir + "/cfg.yaml"}).exit_code == 0);
  const pid_t run = test::spawn({VARBO_EXE, "run", dir + "/cfg.yaml", "-o", dir + "/out", "--study", url,
                                 "--no-progress"}, dir + "/run.log");
  wait_until([&] { return count_state(url, TrialState::Pending) == 1; }, 30);
  const pid_t worker = test::spawn({VARBO_EXE, "worker", url}, dir + "/worker.log");
  std::this_thread::sleep_for(std::chrono::milliseconds(700));
  server.restart(1);  // the run's lock session ends; the run and its command live on
  CHECK(test::wait_for(run).exit_code == 0);
  CHECK(test::wait_for(worker).exit_code == 0);
  const auto trials = open_store(url)->trials();
  const std::string wlog = test::slurp(dir + "/worker.log");
  CAPTURE(wlog);
  CAPTURE(test::slurp(dir + "/run.log"));
  CHECK(trials.size() == 1);  // before: the worker abandoned trial 0 and ran its θ as trial 1
  CHECK(count_state(url, TrialState::Complete) == 1);
  CHECK(wlog.find("that is gone") == std::string::npos);
}

TEST_CASE("postgresql: a killed `varbo run` holds the study until its command has stopped") {
  const std::string dir = test::temp_folder("pg_live_run_kill");
  const std::string url = test::pg_study_url("live_run_kill");
  const std::string marks = dir + "/marks.txt";
  // The command takes 2 s to reach a safe state after SIGTERM (a robot parking its arm).
  std::ofstream(dir + "/trial.sh") << "#!/bin/sh\n"
                                      "echo start >> " << marks << "\n"
                                      "trap 'sleep 2; echo safe >> " << marks << "; exit 1' TERM\n"
                                      "cat > /dev/null\nsleep 30 &\nwait\necho 1.5\n";
  std::filesystem::permissions(dir + "/trial.sh", std::filesystem::perms::owner_all);
  std::ofstream(dir + "/cfg.yaml") << "task: {type: external, command: " << dir << "/trial.sh, dim: 2, grace: 6}\n"
                                      "budget: 1\nseed: 3\nheartbeat_timeout: 1\nalgorithm: {type: random}\n";
  REQUIRE(test::run({VARBO_EXE, "study", "create", url, dir + "/cfg.yaml"}).exit_code == 0);
  const pid_t run = test::spawn({VARBO_EXE, "run", dir + "/cfg.yaml", "-o", dir + "/out", "--study", url,
                                 "--no-progress"}, dir + "/run.log");
  wait_until([&] { return test::slurp(marks).find("start") != std::string::npos; }, 30);
  ::kill(run, SIGKILL);
  test::wait_for(run);
  const pid_t worker = test::spawn({VARBO_EXE, "worker", url}, dir + "/worker.log");
  CHECK(test::wait_for(worker).exit_code == 0);
  const std::string text = test::slurp(marks);
  CAPTURE(text);
  CAPTURE(test::slurp(dir + "/worker.log"));
  // start (the run's), safe (its command stopped), then start (the worker's trial): never two at once.
  CHECK(text.rfind("start\nsafe\nstart\n", 0) == 0);
}

TEST_CASE("postgresql: after an outage longer than heartbeat_timeout, the workers back first abandon no live trial") {
  const std::string dir = test::temp_folder("pg_live_outage");
  OwnServer server(dir);
  const std::string url = server.base + "&study=outage";
  std::ofstream(dir + "/cfg.yaml") << "task: {type: external, command: 'cat > /dev/null; sleep 3; echo 1.5', dim: 2}\n"
                                      "budget: 4\nseed: 3\nheartbeat_timeout: 2\nalgorithm: {type: random}\n";
  REQUIRE(test::run({VARBO_EXE, "study", "create", url, dir + "/cfg.yaml"}).exit_code == 0);
  std::vector<pid_t> workers;
  for (int i = 0; i < 3; ++i)
    workers.push_back(test::spawn({VARBO_EXE, "worker", url}, dir + "/worker" + std::to_string(i) + ".log"));
  wait_until([&] { return count_state(url, TrialState::Pending) == 3; }, 30);
  server.restart(5);  // longer than heartbeat_timeout: nobody can beat meanwhile
  for (const pid_t w : workers) CHECK(test::wait_for(w).exit_code == 0);
  const auto trials = open_store(url)->trials();
  std::string logs;
  for (int i = 0; i < 3; ++i) logs += test::slurp(dir + "/worker" + std::to_string(i) + ".log");
  CAPTURE(logs);
  CHECK(count_state(url, TrialState::Abandoned) == 0);  // before: "abandoned: worker … silent for 6 s"
  CHECK(count_state(url, TrialState::Complete) == 4);
  check_distinct_thetas(trials);
}

TEST_CASE("postgresql: a process that asks just after a server restart does not take the outage for silence") {
  // A fresh `varbo suggest` never lost contact itself: before, it read every worker's heartbeat as old as the outage
  // and abandoned their trials. Now no silence counts longer than the server's uptime.
  const std::string dir = test::temp_folder("pg_live_uptime");
  OwnServer server(dir);
  const std::string url = server.base + "&study=uptime";
  std::ofstream(dir + "/cfg.yaml") << "task: {type: branin}\nbudget: 3\nseed: 3\nheartbeat_timeout: 3\n"
                                      "algorithm: {type: random}\n";
  REQUIRE(test::run({VARBO_EXE, "study", "create", url, dir + "/cfg.yaml"}).exit_code == 0);
  {
    Study rig = Study::open(url);  // a worker whose trial runs
    rig.set_worker(default_worker_name() + ":rig");
    rig.heartbeat();
    REQUIRE(rig.ask(1).size() == 1);
  }
  server.restart(4.5);  // longer than heartbeat_timeout
  CHECK(test::run({VARBO_EXE, "suggest", url}, dir + "/suggest.log").exit_code == 0);
  CAPTURE(test::slurp(dir + "/suggest.log"));
  CHECK(count_state(url, TrialState::Abandoned) == 0);
  CHECK(count_state(url, TrialState::Pending) == 2);
  // The rig really is silent now: once the server has been up for heartbeat_timeout, its trial is abandoned.
  std::this_thread::sleep_for(std::chrono::milliseconds(3500));
  CHECK(test::run({VARBO_EXE, "suggest", url}, dir + "/suggest.log").exit_code == 0);
  CHECK(count_state(url, TrialState::Abandoned) == 1);
}

TEST_CASE("postgresql: Study::retract_failures is refused while a run holds the study or a worker works on it") {
  // The CLI refused both; the library (Python's Study.retract_failures) went through on PostgreSQL, where the run
  // lock is a server session, not a lock file (red team, session 49).
  const std::string url = test::pg_study_url("retract_live");
  Study::create_from_yaml(url, "task: {type: branin}\nbudget: 6\nseed: 3\nheartbeat_timeout: 30\nalgorithm: {type: bo}\n");
  Vec theta(2);
  theta << 1.0, 2.0;
  const std::int64_t id = Study::open(url).fail_point(theta, "E-stop");
  {
    const DatabaseRunLock run = DatabaseRunLock::acquire(url);  // as `varbo run` holds it
    Study s = Study::open(url);
    CHECK_THROWS_WITH_AS(s.retract_failures({id}, "E-stop"), doctest::Contains("a `varbo run` is using this study"),
                         InputError);
  }
  {
    Study worker = Study::open(url);
    worker.set_worker(default_worker_name() + ":worker");
    worker.heartbeat();
    Study s = Study::open(url);
    CHECK_THROWS_WITH_AS(s.retract_failures({id}, "E-stop"), doctest::Contains("is working on this study"),
                         InputError);
    worker.heartbeat("stopped");
  }
  CHECK(Study::open(url).retract_failures({id}, "E-stop") == std::vector<std::int64_t>{id});
}

namespace {
/// A trial command that takes 2 s to reach a safe state after SIGTERM, writing start / safe to `marks`.
void write_slow_stopping_trial(const std::string& dir, const std::string& marks) {
  std::ofstream(dir + "/trial.sh") << "#!/bin/sh\n"
                                      "echo start >> " << marks << "\n"
                                      "trap 'sleep 2; echo safe >> " << marks << "; exit 1' TERM\n"
                                      "cat > /dev/null\nsleep 30 &\nwait\necho 1.5\n";
  std::filesystem::permissions(dir + "/trial.sh", std::filesystem::perms::owner_all);
}
}  // namespace

TEST_CASE("a killed worker's trial is taken over only once its command has had its grace to stop (both backends)") {
  // Re-audit, session 49: a worker SIGKILLed mid-trial was judged dead after heartbeat_timeout, and the next worker
  // ran its θ while the old command was still in its grace period (parking the robot).
  for (const auto backend : test::all_backends()) {
    CAPTURE(test::backend_name(backend));
    const std::string dir = test::temp_folder(std::string("live_worker_kill_") + test::backend_name(backend));
    const std::string store = test::study_address(backend, dir, "kill");
    const std::string marks = dir + "/marks.txt";
    write_slow_stopping_trial(dir, marks);
    std::ofstream(dir + "/cfg.yaml") << "task: {type: external, command: " << dir << "/trial.sh, dim: 2, grace: 4}\n"
                                        "budget: 1\nseed: 3\nheartbeat_timeout: 1\nalgorithm: {type: random}\n";
    REQUIRE(test::run({VARBO_EXE, "study", "create", store, dir + "/cfg.yaml"}).exit_code == 0);
    const pid_t first = test::spawn({VARBO_EXE, "worker", store}, dir + "/first.log");
    wait_until([&] { return test::slurp(marks).find("start") != std::string::npos; }, 30);
    ::kill(first, SIGKILL);
    test::wait_for(first);
    CHECK(test::run({VARBO_EXE, "worker", store}, dir + "/second.log").exit_code == 0);
    const std::string text = test::slurp(marks);
    CAPTURE(text);
    CAPTURE(test::slurp(dir + "/second.log"));
    CHECK(text.rfind("start\nsafe\nstart\n", 0) == 0);
  }
}

TEST_CASE("postgresql: a restart, then SIGKILL of `varbo run`: its θ waits for its command to stop") {
  // Re-audit, session 49: after the restart the lock's session (kept by the supervisor) was gone, so only the run's
  // heartbeat held the trial, and the worker took it over heartbeat_timeout after the kill, beside the old command.
  const std::string dir = test::temp_folder("pg_live_restart_kill");
  OwnServer server(dir);
  const std::string url = server.base + "&study=restart_kill";
  const std::string marks = dir + "/marks.txt";
  write_slow_stopping_trial(dir, marks);
  std::ofstream(dir + "/cfg.yaml") << "task: {type: external, command: " << dir << "/trial.sh, dim: 2, grace: 4}\n"
                                      "budget: 1\nseed: 3\nheartbeat_timeout: 1\nalgorithm: {type: random}\n";
  REQUIRE(test::run({VARBO_EXE, "study", "create", url, dir + "/cfg.yaml"}).exit_code == 0);
  const pid_t run = test::spawn({VARBO_EXE, "run", dir + "/cfg.yaml", "-o", dir + "/out", "--study", url,
                                 "--no-progress"}, dir + "/run.log");
  wait_until([&] { return test::slurp(marks).find("start") != std::string::npos; }, 30);
  const pid_t worker = test::spawn({VARBO_EXE, "worker", url}, dir + "/worker.log");
  server.restart(1);
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));  // the run's heartbeats resumed
  ::kill(run, SIGKILL);
  test::wait_for(run);
  CHECK(test::wait_for(worker).exit_code == 0);
  const std::string text = test::slurp(marks);
  CAPTURE(text);
  CAPTURE(test::slurp(dir + "/worker.log"));
  CHECK(text.rfind("start\nsafe\nstart\n", 0) == 0);
}

TEST_CASE("postgresql: after a restart, a second run, `varbo abandon` and a retraction leave the live run's trial") {
  // Re-audit, session 49: the restart freed the lock; a second `varbo run` took the study and abandoned the live
  // run's trial, `varbo abandon --id 0` abandoned it, and `varbo retract` went through beside the live run.
  const std::string dir = test::temp_folder("pg_live_restart_others");
  OwnServer server(dir);
  const std::string url = server.base + "&study=restart_others";
  std::ofstream(dir + "/cfg.yaml") << "task: {type: external, command: 'cat > /dev/null; sleep 6; echo 1.5', dim: 2}\n"
                                      "budget: 2\nseed: 3\nheartbeat_timeout: 4\nalgorithm: {type: bo}\n";
  REQUIRE(test::run({VARBO_EXE, "study", "create", url, dir + "/cfg.yaml"}).exit_code == 0);
  REQUIRE(test::run({VARBO_EXE, "fail", url, "new", "--theta", "0.5,0.5", "--reason", "E-stop"}).exit_code == 0);
  const pid_t run = test::spawn({VARBO_EXE, "run", dir + "/cfg.yaml", "-o", dir + "/out", "--study", url,
                                 "--no-progress"}, dir + "/run.log");
  wait_until([&] { return count_state(url, TrialState::Pending) == 1; }, 30);
  server.restart(1);
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  const auto second = test::run({VARBO_EXE, "run", dir + "/cfg.yaml", "-o", dir + "/out2", "--study", url,
                                 "--no-progress"}, dir + "/second.log");
  CHECK(second.exit_code == 2);
  CHECK(test::slurp(dir + "/second.log").find("is in use by another run") != std::string::npos);
  test::run({VARBO_EXE, "abandon", url, "--id", "1"}, dir + "/abandon.log");
  CAPTURE(test::slurp(dir + "/abandon.log"));
  CHECK(count_state(url, TrialState::Abandoned) == 0);
  CHECK(count_state(url, TrialState::Pending) == 1);
  CHECK(test::run({VARBO_EXE, "retract", url, "--id", "0"}, dir + "/retract.log").exit_code == 2);
  CHECK(test::slurp(dir + "/retract.log").find("a `varbo run` is using this study") != std::string::npos);
  CHECK(test::wait_for(run).exit_code == 0);
  CAPTURE(test::slurp(dir + "/run.log"));
  CHECK(count_state(url, TrialState::Complete) == 1);
  CHECK(count_state(url, TrialState::Failed) == 1);
  CHECK(open_store(url)->trials().size() == 2);
}

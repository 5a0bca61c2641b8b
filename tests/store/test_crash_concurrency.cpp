// Crash safety and concurrency of the study store, with real processes:
//  - `varbo run` killed with SIGKILL at seeded random moments, resumed each time: the final trials equal an
//    uninterrupted run's and no trial completed before a kill is lost or changed;
//  - 4 processes × 50 suggest/observe cycles on one store: every observation present exactly once;
//  - fault injection: SIGKILL at random instants of `varbo run`, `varbo suggest`, `varbo observe`, `varbo worker`
//    and worker loops (VARBO_FAULT_KILLS kills: 120 in the long label, 10 in the default suite as `store_faults`), the
//    store checked after every kill: intact, no trial lost, changed or duplicated.
#include <sqlite3.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "process.hpp"
#include "study_helpers.hpp"
#include "varbo/csv.hpp"
#include "varbo/store.hpp"
#include "varbo/study_api.hpp"
#include "varbo_test.hpp"

using namespace varbo;

namespace {

std::vector<std::vector<std::string>> without_timings(std::vector<std::vector<std::string>> rows) {
  REQUIRE_FALSE(rows.empty());
  const auto h = rows[0];
  std::vector<int> drop = {test::column_of(h, "fit_seconds"), test::column_of(h, "acquisition_seconds"),
                           test::column_of(h, "evaluation_seconds")};
  std::sort(drop.rbegin(), drop.rend());
  for (auto& r : rows)
    for (int c : drop)
      if (c >= 0 && c < static_cast<int>(r.size())) r.erase(r.begin() + c);
  return rows;
}

struct Done {
  Vec x;
  double cost;
};

std::map<std::int64_t, Done> completed(const std::string& db) {
  std::map<std::int64_t, Done> out;
  if (!std::filesystem::exists(db)) return out;
  auto store = open_sqlite_store(db);
  for (const auto& t : store->trials())
    if (t.state == TrialState::Complete) out[t.id] = Done{t.x, t.cost};
  return out;
}

}  // namespace

TEST_CASE("crash: varbo run killed 8 times at random moments and resumed equals the uninterrupted run") {
  const std::string dir = test::temp_folder("crash_run");
  const std::string cfg = dir + "/study.yaml";
  // Noisy task (its noise stream is per trial index) and a GP model: the replay must reproduce both.
  std::ofstream(cfg) << "task: {type: branin, noise_std: 0.1}\nbudget: 60\nseed: 11\nthreads: 1\n"
                        "algorithm: {type: bo, initial_points: 5}\n";
  const std::string V = VARBO_EXE;
  const std::string full = dir + "/full", cut = dir + "/cut", log = dir + "/log.txt";
  const auto t0 = std::chrono::steady_clock::now();
  REQUIRE(test::run({V, "-q", "run", cfg, "-o", full, "--no-progress"}, log).exit_code == 0);
  const double full_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  MESSAGE("uninterrupted run: " << full_seconds << " s");

  Rng rng(2024);
  int kills = 0, sessions = 0;
  std::map<std::int64_t, Done> seen;  // every trial ever seen complete must stay, unchanged
  while (kills < 8 && sessions < 40) {
    ++sessions;
    const bool fresh = !std::filesystem::exists(cut + "/study.db");
    std::vector<std::string> args = fresh ? std::vector<std::string>{V, "-q", "run", cfg, "-o", cut, "--no-progress"}
                                          : std::vector<std::string>{V, "-q", "run", "--resume", cut, "--no-progress"};
    // Session 1 is killed during start-up; later ones once a seeded random number of new trials is complete,
    // plus a random 0-10 ms, so kills land anywhere: during replay, fitting, between commit and trials.csv.
    const std::size_t before = completed(cut + "/study.db").size();
    const std::size_t left = 60 - before;
    const std::size_t target =
        before + 1 + static_cast<std::size_t>(rng.index(static_cast<Index>(std::max<std::size_t>(1, left / 10))));
    const pid_t pid = test::spawn(args, log);
    const auto start = std::chrono::steady_clock::now();
    test::ProcessResult r;
    bool ended = false;
    for (;;) {
      int status = 0;
      if (waitpid(pid, &status, WNOHANG) == pid) {
        r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
        ended = true;
        break;
      }
      const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      if (sessions == 1 ? elapsed > 0.02 : completed(cut + "/study.db").size() >= target) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    const double delay = rng.uniform(0.0, 0.01);
    if (!ended) {
      std::this_thread::sleep_for(std::chrono::duration<double>(delay));
      kill(pid, SIGKILL);
      r = test::wait_for(pid);
    }
    const auto now = completed(cut + "/study.db");
    for (const auto& [id, d] : seen) {
      REQUIRE(now.count(id) == 1);  // no completed trial lost
      CHECK(now.at(id).x == d.x);
      CHECK(now.at(id).cost == d.cost);
    }
    MESSAGE("session " << sessions << ": killed " << delay << " s after reaching the target: " << now.size() << " complete trials");
    seen = now;
    if (!r.killed) {
      REQUIRE(r.exit_code == 0);
      break;  // finished before the kill
    }
    ++kills;
  }
  MESSAGE(kills << " kills in " << sessions << " sessions");
  CHECK(kills >= 4);
  REQUIRE(test::run({V, "-q", "run", "--resume", cut, "--no-progress"}, log).exit_code == 0);
  const auto a = without_timings(test::read_rows(full + "/trials.csv"));
  const auto b = without_timings(test::read_rows(cut + "/trials.csv"));
  REQUIRE(a.size() == 61);
  CHECK(a == b);
  std::ifstream ma(full + "/model.yaml"), mb(cut + "/model.yaml");
  std::stringstream sa, sb;
  sa << ma.rdbuf();
  sb << mb.rdbuf();
  CHECK(sa.str() == sb.str());
  CHECK(completed(cut + "/study.db").size() == 60);
  std::ifstream lg(log);
  std::stringstream ls;
  ls << lg.rdbuf();
  CHECK(ls.str().find("did not reproduce") == std::string::npos);  // every replay was exact
}

TEST_CASE("concurrency: 4 processes x 50 suggest/observe cycles; every observation present exactly once") {
  const std::string dir = test::temp_folder("concurrency");
  const std::string db = dir + "/s.db";
  { Study::create_from_yaml(db, "task: {type: branin}\nbudget: 200\nseed: 9\nalgorithm: {type: random}\n"); }
  std::vector<pid_t> pids;
  for (int w = 0; w < 4; ++w) {
    std::string name = "w";
    name += std::to_string(w);
    pids.push_back(test::spawn({STORE_WORKER_EXE, db, "50", name}, dir + "/worker.log"));
  }
  for (pid_t p : pids) CHECK(test::wait_for(p).exit_code == 0);
  auto store = open_sqlite_store(db);
  const auto trials = store->trials();
  REQUIRE(trials.size() == 200);
  std::map<std::string, std::vector<int>> cycles;
  std::vector<std::int64_t> seqs;
  for (const auto& t : trials) {
    CHECK(t.state == TrialState::Complete);
    CHECK(t.cost == t.theta.squaredNorm());  // the result belongs to this trial's θ
    REQUIRE(t.components.size() == 1);
    cycles[t.worker].push_back(static_cast<int>(t.components[0].second));
    seqs.push_back(t.finish_seq);
  }
  REQUIRE(cycles.size() == 4);
  for (auto& [w, c] : cycles) {
    std::sort(c.begin(), c.end());
    std::vector<int> expect(50);
    for (int i = 0; i < 50; ++i) expect[static_cast<std::size_t>(i)] = i;
    CHECK_MESSAGE(c == expect, "worker " << w);  // each of its 50 observations exactly once
  }
  std::sort(seqs.begin(), seqs.end());
  for (std::size_t i = 0; i < seqs.size(); ++i) CHECK(seqs[i] == static_cast<std::int64_t>(i));
  // Random search hands out sample k to the k-th trial: 200 distinct points.
  std::vector<Vec> xs;
  for (const auto& t : trials) xs.push_back(t.x);
  int duplicates = 0;
  for (std::size_t i = 0; i < xs.size(); ++i)
    for (std::size_t j = i + 1; j < xs.size(); ++j) duplicates += xs[i] == xs[j] ? 1 : 0;
  CHECK(duplicates == 0);
}

TEST_CASE("crash: varbo suggest killed at random instants leaves a consistent store and loses no result") {
  const std::string dir = test::temp_folder("crash_suggest");
  const std::string db = dir + "/s.db";
  {
    Study s = Study::create_from_yaml(db, "task: {type: branin}\nbudget: 100\nseed: 4\n"
                                          "algorithm: {type: bo, initial_points: 4}\n");
    for (int i = 0; i < 8; ++i) {
      const auto t = s.ask().at(0);
      s.tell(t.id, t.theta.squaredNorm());
    }
  }
  const auto before = completed(db);
  Rng rng(77);
  const std::string V = VARBO_EXE;
  int killed = 0;
  for (int i = 0; i < 8; ++i) {
    const auto r = test::run_and_kill({V, "-q", "suggest", db, "--batch", "2"}, rng.uniform(0.002, 0.06),
                                      dir + "/log.txt");
    killed += r.killed ? 1 : 0;
    if (!r.killed) CHECK(r.exit_code == 0);
  }
  MESSAGE(killed << " of 8 suggest processes killed");
  Study s = Study::open(db);  // opens fine: every transaction either committed or vanished
  const auto after = completed(db);
  CHECK(after.size() == before.size());
  for (const auto& [id, d] : before) {
    REQUIRE(after.count(id) == 1);
    CHECK(after.at(id).cost == d.cost);
  }
  for (const auto& t : s.trials()) {
    if (t.state != TrialState::Pending) continue;
    CHECK(t.batch_size == 2);  // a suggestion is stored whole or not at all
  }
  const auto more = s.ask(1);
  CHECK(more.size() == 1);
}

namespace {

int fault_kills() {
  const char* e = std::getenv("VARBO_FAULT_KILLS");
  return e ? std::max(1, std::atoi(e)) : 120;
}

/// SQLite's own check of the file: pages, indexes, free list.
std::string integrity(const std::string& db) {
  sqlite3* h = nullptr;
  std::string out = "cannot open";
  if (sqlite3_open_v2(db.c_str(), &h, SQLITE_OPEN_READONLY, nullptr) == SQLITE_OK) {
    sqlite3_stmt* st = nullptr;
    if (sqlite3_prepare_v2(h, "PRAGMA integrity_check", -1, &st, nullptr) == SQLITE_OK && sqlite3_step(st) == SQLITE_ROW)
      out = reinterpret_cast<const char*>(sqlite3_column_text(st, 0));
    sqlite3_finalize(st);
  }
  sqlite3_close(h);
  return out;
}

/// The invariants of a study store after any crash: SQLite-consistent; ids 0..n-1; each result recorded once
/// (finish_seq 0..m-1 over finished trials); each suggested batch stored whole; every trial ever seen complete
/// still complete with the same point and cost (`seen` is updated). With `squared_norm_costs`, each complete
/// trial's cost is |θ|² of its own θ: a result never lands on another trial.
void check_store(const std::string& db, std::map<std::int64_t, Done>& seen, bool squared_norm_costs) {
  if (!std::filesystem::exists(db)) {
    REQUIRE(seen.empty());
    return;
  }
  REQUIRE(integrity(db) == "ok");
  const auto trials = open_sqlite_store(db)->trials();
  std::vector<std::int64_t> seqs;
  std::map<std::pair<std::string, double>, std::int64_t> batches;
  for (std::size_t i = 0; i < trials.size(); ++i) {
    const TrialRecord& t = trials[i];
    REQUIRE(t.id == static_cast<std::int64_t>(i));
    if (t.finished()) seqs.push_back(t.finish_seq);
    if (t.batch_size >= 1) ++batches[{t.worker, t.created_at}];
    if (squared_norm_costs && t.state == TrialState::Complete) CHECK(t.cost == t.theta.squaredNorm());
  }
  for (const auto& t : trials)
    if (t.batch_size >= 1) CHECK(batches[{t.worker, t.created_at}] == t.batch_size);
  std::sort(seqs.begin(), seqs.end());
  for (std::size_t i = 0; i < seqs.size(); ++i) REQUIRE(seqs[i] == static_cast<std::int64_t>(i));
  for (const auto& [id, d] : seen) {
    REQUIRE(static_cast<std::size_t>(id) < trials.size());
    const TrialRecord& t = trials[static_cast<std::size_t>(id)];
    REQUIRE(t.state == TrialState::Complete);
    CHECK(t.x == d.x);
    CHECK(t.cost == d.cost);
  }
  seen.clear();
  for (const auto& t : trials)
    if (t.state == TrialState::Complete) seen[t.id] = Done{t.x, t.cost};
}

/// Ids printed by a `varbo suggest` that ended normally ("trial 3 x1=... (phase)").
std::vector<std::int64_t> suggested_ids(const std::string& out) {
  std::vector<std::int64_t> ids;
  std::stringstream ss(out);
  for (std::string line; std::getline(ss, line);)
    if (line.rfind("trial ", 0) == 0) ids.push_back(std::stoll(line.substr(6)));
  return ids;
}

std::string slurp_file(const std::string& f) {
  std::ifstream in(f);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace

TEST_CASE("fault injection: SIGKILL of run, suggest, observe and worker loops at random instants") {
  const int target = fault_kills();
  const std::string dir = test::temp_folder("fault_injection_" + std::to_string(getpid()));
  const std::string V = VARBO_EXE, log = dir + "/log.txt";
  // The driven run: a GP model (fits take time, kills land inside them) on a noisy task.
  const std::string run_cfg = dir + "/run.yaml";
  std::ofstream(run_cfg) << "task: {type: branin, noise_std: 0.1}\nbudget: 16\nseed: 5\nthreads: 1\n"
                            "algorithm: {type: bo, initial_points: 4, surrogate: {type: gp, restarts: 1}}\n";
  const auto t0 = std::chrono::steady_clock::now();
  REQUIRE(test::run({V, "-q", "run", run_cfg, "-o", dir + "/reference", "--no-progress"}, log).exit_code == 0);
  const double run_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const auto reference = without_timings(test::read_rows(dir + "/reference/trials.csv"));
  // The shared study of the external workers: BO too, rotated when its budget is spent (replays stay short).
  const std::string study_cfg = dir + "/study.yaml";
  std::ofstream(study_cfg) << "task: {type: branin}\nbudget: 24\nseed: 6\nthreads: 1\n"
                              "algorithm: {type: bo, initial_points: 6, surrogate: {type: gp, restarts: 1}}\n";

  // The command of `varbo worker`: |θ|² of the θ on its stdin (the external task's JSON), printed exactly.
  const std::string norm_script = dir + "/norm.sh";
  std::ofstream(norm_script) << "#!/bin/sh\ntheta=$(sed 's/.*\"theta\": *\\[\\([^]]*\\)\\].*/\\1/')\n"
                             << "echo \"$theta\" | awk -F, '{printf \"%.17g\\n\", $1*$1 + $2*$2}'\n";
  const std::string norm_command = "sh " + norm_script;
  Rng rng(20261201);
  std::map<std::string, int> kills, ended;
  int total = 0, runs_done = 0, studies = 0;
  std::string cut = dir + "/cut0", db;
  std::map<std::int64_t, Done> seen_run, seen_study;
  std::vector<std::int64_t> owned;  // pending trials whose suggestion the test received
  auto new_study = [&] {
    db = dir + "/s" + std::to_string(studies++) + ".db";
    REQUIRE(test::run({V, "study", "create", db, study_cfg}, log).exit_code == 0);
    seen_study.clear();
    owned.clear();
  };
  new_study();
  // How long a looping worker takes to use a fresh study's budget, uninterrupted: its kill instants are drawn
  // within that (a fixed second had it finish first in ~3 of 4 draws on a fast machine: too few kills).
  double worker_seconds = 0;
  {
    const std::string scratch = dir + "/scratch.db";
    REQUIRE(test::run({V, "study", "create", scratch, study_cfg}, log).exit_code == 0);
    const auto t1 = std::chrono::steady_clock::now();
    REQUIRE(test::run({STORE_WORKER_EXE, scratch, "1000", "timing"}, log).exit_code != 0);  // ends: budget used
    worker_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
  }
  auto count = [&](const std::string& what, const test::ProcessResult& r) {
    if (r.killed) {
      ++kills[what];
      ++total;
    } else {
      ++ended[what];
    }
  };

  for (int step = 0; total < target && step < 40 * target; ++step) {
    const double u = rng.uniform(0.0, 1.0);
    if (u < 0.3) {  // varbo run / --resume, killed anywhere from start-up to the last trial
      const bool fresh = !std::filesystem::exists(cut + "/study.db");
      std::vector<std::string> args = fresh ? std::vector<std::string>{V, "-q", "run", run_cfg, "-o", cut, "--no-progress"}
                                            : std::vector<std::string>{V, "-q", "run", "--resume", cut, "--no-progress"};
      const auto r = test::run_and_kill(args, rng.uniform(0.0, run_seconds), log);
      count("run", r);
      check_store(cut + "/study.db", seen_run, false);
      if (!r.killed) {
        REQUIRE(r.exit_code == 0);
        CHECK(without_timings(test::read_rows(cut + "/trials.csv")) == reference);  // as if never killed
        ++runs_done;
        cut = dir + "/cut" + std::to_string(runs_done);
        seen_run.clear();
      }
    } else if (u < 0.55) {  // varbo suggest --batch 1..3
      const std::string out = dir + "/suggest.txt";
      std::filesystem::remove(out);
      const auto r = test::run_and_kill({V, "-q", "suggest", db, "--batch", std::to_string(1 + rng.index(3))},
                                        rng.uniform(0.0, 0.4), out);
      count("suggest", r);
      if (!r.killed && r.exit_code == 0) {
        for (auto id : suggested_ids(slurp_file(out))) owned.push_back(id);
      } else if (!r.killed) {
        CHECK(slurp_file(out).find("nothing to suggest") != std::string::npos);  // budget spent
        std::string abandon_log = dir + "/abandon.txt";
        REQUIRE(test::run({V, "abandon", db}, abandon_log).exit_code == 0);
        check_store(db, seen_study, true);
        new_study();
      }
      check_store(db, seen_study, true);
    } else if (u < 0.8) {  // varbo observe of a trial the test owns: the result lands once or not at all
      if (owned.empty()) continue;
      const std::size_t k = static_cast<std::size_t>(rng.index(static_cast<Index>(owned.size())));
      const std::int64_t id = owned[k];
      const auto t = open_sqlite_store(db)->trial(id);
      REQUIRE(t.has_value());
      const std::string cost = exact(t->theta.squaredNorm());
      const std::string out = dir + "/observe.txt";
      std::filesystem::remove(out);
      const auto r = test::run_and_kill({V, "-q", "observe", db, std::to_string(id), cost}, rng.uniform(0.0, 0.3), out);
      count("observe", r);
      const auto after = open_sqlite_store(db)->trial(id);
      REQUIRE(after.has_value());
      if (!r.killed) {
        // 0, or 2 when an earlier, killed observe had committed just before dying.
        CHECK_MESSAGE((r.exit_code == 0 || (r.exit_code == 2 && slurp_file(out).find("already complete") != std::string::npos)),
                      slurp_file(out));
        REQUIRE(after->state == TrialState::Complete);
      } else {
        REQUIRE((after->state == TrialState::Pending || after->state == TrialState::Complete));
      }
      if (after->state == TrialState::Complete) owned.erase(owned.begin() + static_cast<std::ptrdiff_t>(k));
      check_store(db, seen_study, true);
    } else if (u < 0.9) {  // `varbo worker`: suggest, run the command, record, repeat
      const auto r = test::run_and_kill({V, "-q", "worker", db, "--command", norm_command}, rng.uniform(0.0, 1.5), log);
      count("varbo worker", r);
      check_store(db, seen_study, true);
      if (!r.killed) {  // the budget is used: start over on a new study
        REQUIRE(r.exit_code == 0);
        REQUIRE(test::run({V, "abandon", db}, log).exit_code == 0);
        check_store(db, seen_study, true);
        new_study();
      }
    } else {  // a worker looping open / ask / tell
      const auto r = test::run_and_kill({STORE_WORKER_EXE, db, "1000", "loop" + std::to_string(step)},
                                        rng.uniform(0.0, worker_seconds), log);
      count("worker", r);
      check_store(db, seen_study, true);
      if (!r.killed) {  // it ran out of budget: start over on a new study
        REQUIRE(test::run({V, "abandon", db}, log).exit_code == 0);
        check_store(db, seen_study, true);
        new_study();
      }
    }
  }
  MESSAGE(total << " kills: run " << kills["run"] << ", suggest " << kills["suggest"] << ", observe "
                << kills["observe"] << ", worker " << kills["worker"] << ", varbo worker " << kills["varbo worker"]
                << "; ended normally: run " << ended["run"]
                << ", suggest " << ended["suggest"] << ", observe " << ended["observe"] << ", worker " << ended["worker"]
                << "; " << runs_done << " runs completed, " << studies << " studies");
  CHECK(total >= target);
  if (target >= 100)  // the long version: every kind of process was killed, repeatedly
    for (const char* what : {"run", "suggest", "observe", "worker", "varbo worker"}) CHECK_MESSAGE(kills[what] >= 5, what);
  // Whatever was left: a pending trial of a killed suggest or worker is abandoned (the documented recovery) and
  // both stores continue: the run to its budget, equal to the uninterrupted one; the study with a new trial.
  if (std::filesystem::exists(cut + "/study.db")) {
    REQUIRE(test::run({V, "-q", "run", "--resume", cut, "--no-progress"}, log).exit_code == 0);
    CHECK(without_timings(test::read_rows(cut + "/trials.csv")) == reference);
    check_store(cut + "/study.db", seen_run, false);
  }
  REQUIRE(test::run({V, "abandon", db}, log).exit_code == 0);
  check_store(db, seen_study, true);
  Study s = Study::open(db);
  const auto more = s.ask(1);
  if (!more.empty()) s.tell(more[0].id, more[0].theta.squaredNorm());
  check_store(db, seen_study, true);
  CHECK(slurp_file(log).find("did not reproduce") == std::string::npos);
  std::filesystem::remove_all(dir);
}

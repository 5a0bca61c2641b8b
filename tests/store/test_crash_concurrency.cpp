// Crash safety and concurrency of the study store, with real processes:
//  - `varbo run` killed with SIGKILL at seeded random moments, resumed each time: the final trials equal an
//    uninterrupted run's and no trial completed before a kill is lost or changed;
//  - 4 processes × 50 suggest/observe cycles on one store: every observation present exactly once.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "process.hpp"
#include "study_helpers.hpp"
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

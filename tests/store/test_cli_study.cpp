// The study commands of the `varbo` executable: suggest/observe/fail/status/export and their input errors.
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "process.hpp"
#include "study_helpers.hpp"
#include "varbo/run_lock.hpp"
#include "varbo/store.hpp"
#include "varbo/study_api.hpp"
#include "varbo_test.hpp"

using namespace varbo;
using test::slurp;

namespace {
}  // namespace

TEST_CASE("CLI: create, suggest --json, observe, fail, malformed numbers, status, export") {
  const std::string dir = test::temp_folder("cli_study");
  const std::string cfg = dir + "/cfg.yaml", db = dir + "/s.db", log = dir + "/log.txt";
  std::ofstream(cfg) << "task: {type: branin}\nbudget: 8\nseed: 4\nalgorithm: {type: random}\n";
  const std::string V = VARBO_EXE;
  REQUIRE(test::run({V, "study", "create", db, cfg}, log).exit_code == 0);
  CHECK(test::run({V, "study", "create", db, cfg}, log).exit_code == 2);  // exists

  const std::string out = dir + "/suggest.json";
  REQUIRE(test::run({V, "suggest", db, "--batch", "3", "--json"}, out).exit_code == 0);
  const auto j = nlohmann::json::parse(slurp(out));
  REQUIRE(j.size() == 3);
  CHECK(j[0]["id"] == 0);
  CHECK(j[2]["theta"].size() == 2);

  // Malformed or non-finite input: exit code 2, a message, and the store untouched.
  std::filesystem::remove(log);
  CHECK(test::run({V, "observe", db, "0", "1.2.3"}, log).exit_code == 2);
  CHECK(test::run({V, "observe", db, "0", "nan"}, log).exit_code == 2);
  CHECK(test::run({V, "observe", db, "zero", "1"}, log).exit_code == 2);
  CHECK(test::run({V, "observe", db, "7", "1"}, log).exit_code == 2);
  CHECK(test::run({V, "observe", db, "0", "1", "--component", "energy"}, log).exit_code == 2);
  CHECK(test::run({V, "observe", db, "new", "1", "--theta", "0,99"}, log).exit_code == 2);
  CHECK(test::run({V, "observe", db, "new", "1", "--theta", "0,x"}, log).exit_code == 2);
  const std::string errors = slurp(log);
  CHECK(errors.find("malformed number '1.2.3'") != std::string::npos);
  CHECK(errors.find("finite number, got nan") != std::string::npos);
  CHECK(errors.find("malformed trial id 'zero'") != std::string::npos);
  CHECK(errors.find("no trial with id 7") != std::string::npos);
  CHECK(errors.find("expected name=value") != std::string::npos);
  CHECK(errors.find("outside the domain") != std::string::npos);
  {
    auto store = open_sqlite_store(db);
    for (const auto& t : store->trials()) CHECK(t.state == TrialState::Pending);
    CHECK(store->trials().size() == 3);
  }

  CHECK(test::run({V, "observe", db, "0", "1.25", "--component", "energy=0.5"}, log).exit_code == 0);
  CHECK(test::run({V, "observe", db, "0", "1.5"}, log).exit_code == 2);  // double observe
  CHECK(test::run({V, "fail", db, "1", "--reason", "motor overheated"}, log).exit_code == 0);
  CHECK(test::run({V, "observe", db, "new", "0.75", "--theta", "1,4"}, log).exit_code == 0);
  CHECK(test::run({V, "abandon", db}, log).exit_code == 0);

  const std::string status = dir + "/status.txt";
  REQUIRE(test::run({V, "status", db}, status).exit_code == 0);
  const std::string st = slurp(status);
  CHECK(st.find("2 complete, 1 failed, 0 pending, 1 abandoned") != std::string::npos);
  CHECK(st.find("best       trial 3: cost 0.75") != std::string::npos);

  const std::string csv = dir + "/trials.csv";
  REQUIRE(test::run({V, "export", db, "--csv", "-o", csv}, log).exit_code == 0);
  const auto rows = test::read_rows(csv);
  REQUIRE(rows.size() == 5);
  CHECK(rows[0][test::column_of(rows[0], "energy")] == "energy");
  CHECK(rows[1][test::column_of(rows[0], "cost")] == "1.25");
  CHECK(rows[1][test::column_of(rows[0], "energy")] == "0.5");
  CHECK(rows[2][test::column_of(rows[0], "state")] == "failed");

  // A foreign file is refused by name.
  std::ofstream(dir + "/notes.db") << "not a database at all, just some text that is long enough.................\n";
  std::filesystem::remove(log);
  CHECK(test::run({V, "status", dir + "/notes.db"}, log).exit_code == 2);
  CHECK(slurp(log).find("notes.db: not a varbo study store") != std::string::npos);
}

TEST_CASE("CLI: a process on a SQLite study loads no PostgreSQL library; a postgresql:// address loads it") {
  // The PostgreSQL store is libvarbo_study_postgres.so, loaded on the first postgresql:// address: libpq and its
  // ~23 dependencies cost every process ~8 ms (docs/studies.md). The dynamic loader's own log says what it loaded.
  const std::string dir = test::temp_folder("cli_lazy_store");
  const std::string cfg = dir + "/cfg.yaml", db = dir + "/s.db", log = dir + "/log.txt";
  std::ofstream(cfg) << "task: {type: branin}\nbudget: 4\nseed: 4\nalgorithm: {type: random}\n";
  const std::string V = VARBO_EXE;
  REQUIRE(test::run({V, "study", "create", db, cfg}, log).exit_code == 0);
  REQUIRE(test::run({"/usr/bin/env", "LD_DEBUG=files", V, "suggest", db}, log).exit_code == 0);
  const std::string sqlite = slurp(log);
  CHECK(sqlite.find("file=libvarbo_study.so") != std::string::npos);  // the log is there...
  CHECK(sqlite.find("libpq") == std::string::npos);                    // ...and names no libpq
  CHECK(sqlite.find("libvarbo_study_postgres") == std::string::npos);
  // A database address loads the store (then fails to connect: no server on that socket folder, exit 2).
  const std::string url = "postgresql:///db?host=/nonexistent-varbo-socket&study=gait";
  CHECK(test::run({"/usr/bin/env", "LD_DEBUG=files", V, "status", url}, log).exit_code == 2);
  const std::string pg = slurp(log);
  CHECK(pg.find("libvarbo_study_postgres.so") != std::string::npos);
  CHECK(pg.find("libpq") != std::string::npos);
  CHECK(pg.find("study=gait: cannot connect to the database server") != std::string::npos);
}

TEST_CASE("CLI: export -o and plot -o to standard output, a pipe or a FIFO write there (no hang, no stray line)") {
  // Red team, session 29: the check that an output file is no study opened the path to read its header, which
  // for `-o /dev/stdout | head` was the read end of varbo's own output pipe: the command hung for good. And
  // `plot -o /dev/stdout > m.svg` printed the file's name over the SVG's first bytes.
  const std::string dir = test::temp_folder("cli_output_streams");
  const std::string cfg = dir + "/cfg.yaml", run = dir + "/r", db = run + "/study.db", log = dir + "/log.txt";
  std::ofstream(cfg) << "task: {type: branin}\nbudget: 6\nseed: 4\nalgorithm: {type: random}\n";
  const std::string V = VARBO_EXE;
  REQUIRE(test::run({V, "-q", "run", cfg, "-o", run, "--no-progress"}, log).exit_code == 0);
  auto sh = [&](const std::string& script) {
    return test::run({"/bin/bash", "-c", "cd \"$1\" && " + script, "bash", dir}, log).exit_code;
  };
  const std::string v = "'" + V + "'";
  CHECK(sh("timeout 20 " + v + " export r/study.db --csv -o /dev/stdout | head -1 > first.txt; "
           "exit ${PIPESTATUS[0]}") == 0);
  CHECK(slurp(dir + "/first.txt").rfind("id,state,phase,x1,x2,cost", 0) == 0);
  CHECK(sh("timeout 20 " + v + " export r/study.db --csv -o - > dash.csv") == 0);
  CHECK(test::read_rows(dir + "/dash.csv").size() == 7);  // header + 6 trials
  CHECK_FALSE(std::filesystem::exists(dir + "/-"));
  CHECK(sh("mkfifo ff && (cat ff > from_fifo.csv &) && timeout 20 " + v + " export r/study.db --csv -o ff") == 0);
  CHECK(sh("for i in $(seq 50); do [ -s from_fifo.csv ] && break; sleep 0.1; done; [ -s from_fifo.csv ]") == 0);
  CHECK(sh("timeout 60 " + v + " plot r -o /dev/stdout > m.svg") == 0);
  CHECK(slurp(dir + "/m.svg").rfind("<svg xmlns=", 0) == 0);
  CHECK(sh("timeout 60 " + v + " plot r -o - > n.svg") == 0);
  CHECK(slurp(dir + "/n.svg") == slurp(dir + "/m.svg"));
  // A file keeps its line naming where the SVG went.
  CHECK(sh(v + " plot r -o x.svg > where.txt") == 0);
  CHECK(slurp(dir + "/where.txt") == "x.svg\n");
}

// Audit, session 48: an E-stop pressed at the start of an overnight study failed its first trials; bo's failure model
// learned them as failures of their θ, and nothing could take them back: the study ended 10⁵× worse than one
// without the outage at the same budget. `varbo retract` takes them back; the algorithm is rebuilt without them.
TEST_CASE("CLI: retract takes back failed trials that were the rig's fault; the study then ends as without them") {
  const std::string dir = test::temp_folder("cli_retract");
  const std::string V = VARBO_EXE, log = dir + "/log.txt";
  const std::string script = dir + "/rig.sh";
  std::ofstream(script) << "#!/bin/sh\n"
                        << "if [ -e " << dir << "/down ]; then echo 'E-stop pressed' >&2; exit 5; fi\n"
                        << "theta=$(sed 's/.*\"theta\": *\\[\\([^]]*\\)\\].*/\\1/')\n"
                        << "echo \"$theta\" | awk -F, '{printf \"%.17g\\n\", ($1-0.3)^2 + ($2-0.7)^2}'\n";
  const std::string cfg = dir + "/cfg.yaml";
  std::ofstream(cfg) << "task: {type: external, command: 'sh " << script << "', dim: 2, bounds: [0, 1]}\n"
                     << "budget: 14\nseed: 1\nstop_after_failures: 3\n";
  const auto best_cost = [&](const std::string& run) {
    const auto j = nlohmann::json::parse(slurp(run + "/summary.json"));
    return j["best_cost"].get<double>();
  };
  // Without the outage.
  REQUIRE(test::run({V, "-q", "run", cfg, "-o", dir + "/plain", "--no-progress"}, log).exit_code == 0);
  // The outage: 3 failed trials, the run stops and names the command that takes them back.
  std::ofstream(dir + "/down") << "";
  for (const std::string& run : {dir + "/kept", dir + "/taken"}) {
    const std::string stop_log = run + ".log";
    REQUIRE(test::run({V, "-q", "run", cfg, "-o", run, "--no-progress"}, stop_log).exit_code == 2);
    CHECK(slurp(stop_log).find("varbo retract " + run + "/study.db --id 0 --id 1 --id 2") != std::string::npos);
  }
  std::filesystem::remove(dir + "/down");
  const std::string db = dir + "/taken/study.db";
  std::filesystem::remove(log);
  CHECK(test::run({V, "retract", db, "--id", "0", "--id", "1", "--id", "2", "--reason", "E-stop"}, log).exit_code == 0);
  CHECK(slurp(log).find("took back 3 failed trial(s): 0, 1, 2") != std::string::npos);
  // Refused, nothing written: one taken back already, a trial that is no failure, an unknown one.
  CHECK(test::run({V, "retract", db, "--id", "0"}, log).exit_code == 2);
  CHECK(test::run({V, "retract", db, "--id", "7"}, log).exit_code == 2);
  CHECK(slurp(log).find("trial 0 was taken back already") != std::string::npos);
  CHECK(slurp(log).find("no trial 7") != std::string::npos);
  // Both resumed with 3 more trials (the failed ones count against the budget): the study whose failures were taken
  // back ends as the one without the outage did; the one that kept them does not.
  for (const std::string& run : {dir + "/kept", dir + "/taken"})
    REQUIRE(test::run({V, "-q", "run", "--resume", run, "--budget", "17", "--no-progress"}, log).exit_code == 0);
  CHECK(best_cost(dir + "/taken") <= best_cost(dir + "/plain"));
  CHECK(best_cost(dir + "/kept") > 100 * best_cost(dir + "/plain"));
  const std::string rows = slurp(dir + "/taken/trials.csv");
  CHECK(rows.find("taken back by `varbo retract` (E-stop); the failure was: external command failed (exit status 5)") !=
        std::string::npos);
  std::filesystem::remove(log);
  CHECK(test::run({V, "retract", db, "--id", "3"}, log).exit_code == 2);  // trial 3 succeeded
  CHECK(slurp(log).find("trial 3 is complete, not failed") != std::string::npos);
  // While a run holds the study, the library refuses too (Python's retract_failures went through beside a live run).
  {
    const RunLock held = RunLock::acquire(RunLock::lock_file_of(dir + "/kept/study.db"), "the test");
    Study kept = Study::open(dir + "/kept/study.db");
    CHECK_THROWS_WITH_AS(kept.retract_failures({0}, "E-stop"), doctest::Contains("a `varbo run` is using this study"),
                         InputError);
  }
  // `study verify` cannot replay a history that changed, and says why.
  std::filesystem::remove(log);
  CHECK(test::run({V, "study", "verify", db}, log).exit_code != 0);
  CHECK(slurp(log).find("was taken back (varbo retract)") != std::string::npos);
}

// The study stores: round trip of every field and rollback on both backends (SQLite, PostgreSQL), the
// schema-version check, and SQLite's foreign-file checks.
#include <sqlite3.h>

#include <pqxx/pqxx>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>

#include "backends.hpp"
#include "study_helpers.hpp"
#include "varbo/errors.hpp"
#include "varbo/log.hpp"
#include "varbo/store.hpp"
#include "varbo/store_retry.hpp"
#include "varbo_test.hpp"

using namespace varbo;

namespace {

void exec_sql(const std::string& file, const std::string& sql) {
  sqlite3* db = nullptr;
  REQUIRE(sqlite3_open(file.c_str(), &db) == SQLITE_OK);
  char* err = nullptr;
  const int rc = sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &err);
  if (err) sqlite3_free(err);
  sqlite3_close(db);
  REQUIRE(rc == SQLITE_OK);
}

/// Pretends a newer varbo wrote the study.
void set_schema_version(const std::string& address, const std::string& version) {
  if (!is_database_url(address)) return exec_sql(address, "UPDATE meta SET value = '" + version + "' WHERE key = 'schema_version'");
  const auto study = address.substr(address.rfind("study=") + 6);
  pqxx::connection c(test::pg_base_url());
  pqxx::work w(c);
  w.exec_params("UPDATE varbo_meta SET value = $1 WHERE study = $2 AND key = 'schema_version'", version, study);
  w.commit();
}

std::string open_error(const std::string& file) {
  try {
    open_store(file);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TrialRecord sample_trial() {
  TrialRecord t;
  t.state = TrialState::Complete;
  t.phase = "ei";
  t.x = (Vec(3) << 0.1, 1.0 / 3.0, 0.999999999999).finished();
  t.theta = (Vec(3) << -4.9, 1e-300, 12345.678901234567).finished();
  t.cost = 0.1 + 0.2;  // not exactly representable in decimal: must come back bit-identical
  t.components = {{"energy", 1.5}, {"tracking, \"quoted\"", -2.25e-7}};
  t.noiseless_cost = std::nan("");
  t.error = "";
  t.worker = "robot-1:42";
  t.created_at = 1.7e9 + 0.125;
  t.finished_at = 1.7e9 + 60.5;
  t.finish_seq = 0;
  t.finished_before = 0;
  t.pending_before = 2;
  t.batch_size = 3;
  t.batch_index = 1;
  t.fit_seconds = 0.25;
  t.acquisition_seconds = 0.5;
  t.evaluation_seconds = 12.0;
  return t;
}

}  // namespace

TEST_CASE("store round trip: meta, every trial field (bit-exact doubles, NaN), updates and snapshots") {
  const std::string dir = test::temp_folder("store_round_trip");
  for (const auto backend : test::all_backends()) {
    CAPTURE(test::backend_name(backend));
    const std::string file = test::study_address(backend, dir, "round_trip");
    const TrialRecord t = sample_trial();
    {
      auto store = create_store(file);
      store->set_meta(store_key::kConfig, "task: {type: branin}\n");
      std::int64_t id0 = -1, id1 = -1;
      store->transaction([&] {
        id0 = store->add_trial(t);
        TrialRecord p = t;
        p.state = TrialState::Pending;
        p.cost = std::nan("");
        p.finish_seq = -1;
        id1 = store->add_trial(p);
      });
      CHECK(id0 == 0);
      CHECK(id1 == 1);
      CHECK(store->next_finish_seq() == 1);
      StoredSnapshot s;
      s.after_trials = 7;
      s.snapshot.iteration = 6;
      s.snapshot.objective = -3.5;
      s.snapshot.note = "fit failed";
      s.snapshot.region_state = "box";
      s.snapshot.hyperparameters = {{"lengthscale[0]", 0.3}, {"signal_std", 2.0}};
      store->add_snapshot(s);
    }
    auto store = open_store(file);  // reopened: everything came from the file
    CHECK(store->location().find(is_database_url(file) ? "study=round_trip_" : "round_trip.db") != std::string::npos);
    CHECK(store->meta(store_key::kConfig).value() == "task: {type: branin}\n");
    CHECK_FALSE(store->meta("no such key").has_value());
    const auto trials = store->trials();
    REQUIRE(trials.size() == 2);
    const TrialRecord& r = trials[0];
    CHECK(r.id == 0);
    CHECK(r.state == TrialState::Complete);
    CHECK(r.phase == "ei");
    CHECK(r.x == t.x);          // bit-exact
    CHECK(r.theta == t.theta);  // bit-exact, including 1e-300
    CHECK(r.cost == t.cost);
    CHECK(r.components == t.components);
    CHECK(std::isnan(r.noiseless_cost));
    CHECK(r.worker == t.worker);
    CHECK(r.created_at == t.created_at);
    CHECK(r.finished_at == t.finished_at);
    CHECK(r.finish_seq == 0);
    CHECK(r.pending_before == 2);
    CHECK(r.batch_size == 3);
    CHECK(r.batch_index == 1);
    CHECK(r.evaluation_seconds == 12.0);
    CHECK(trials[1].state == TrialState::Pending);
    CHECK(std::isnan(trials[1].cost));

    TrialRecord u = trials[1];
    u.state = TrialState::Failed;
    u.error = "emergency stop";
    u.finish_seq = store->next_finish_seq();
    store->update_trial(u);
    CHECK(store->trial(1)->state == TrialState::Failed);
    CHECK(store->trial(1)->error == "emergency stop");
    CHECK(store->trial(1)->finish_seq == 1);
    CHECK_FALSE(store->trial(5).has_value());
    u.id = 5;
    CHECK_THROWS_AS(store->update_trial(u), InputError);

    const auto snaps = store->snapshots();
    REQUIRE(snaps.size() == 1);
    CHECK(snaps[0].after_trials == 7);
    CHECK(snaps[0].snapshot.iteration == 6);
    CHECK(snaps[0].snapshot.objective == -3.5);
    CHECK(snaps[0].snapshot.note == "fit failed");
    CHECK(snaps[0].snapshot.region_state == "box");
    REQUIRE(snaps[0].snapshot.hyperparameters.size() == 2);
    CHECK(snaps[0].snapshot.hyperparameters[0].name == "lengthscale[0]");
    CHECK(snaps[0].snapshot.hyperparameters[1].value == 2.0);

    AlgorithmSnapshot a;
    a.state = "{\"k\": 1}";
    a.created_at = 1.7e9 + 1.0 / 3.0;
    for (std::int64_t f = 0; f < 5; ++f) {
      a.finished = f;
      a.outstanding = f % 2 ? f + 10 : -1;
      store->add_algorithm_state(a);
    }
    const auto states = store->algorithm_states();  // newest first, those more than two results older dropped
    REQUIRE(states.size() == 3);
    CHECK(states[0].finished == 4);
    CHECK(states[1].outstanding == 13);
    CHECK(states[2].finished == 2);
    CHECK(states[0].created_at == a.created_at);
    CHECK(states[0].state == a.state);

    // SQLite keeps the worker's own times; PostgreSQL stamps the server's clock and reads it back in ours.
    const double now = unix_time();
    WorkerRecord w{"robot-1:42:00ff", "robot-1", 42, now - 1, now - 0.5, "running"};
    store->put_worker(w);
    const double first = store->workers().at(0).heartbeat_at;
    w.heartbeat_at = now + 0.25;
    w.state = "stopped";
    store->transaction([&] { store->put_worker(w); });
    const auto workers = store->workers();
    REQUIRE(workers.size() == 1);
    CHECK(workers[0].id == w.id);
    CHECK(workers[0].host == "robot-1");
    CHECK(workers[0].pid == 42);
    if (backend == test::Backend::Sqlite) {
      CHECK(workers[0].heartbeat_at == w.heartbeat_at);
      CHECK(workers[0].started_at == w.started_at);
    } else {
      CHECK(std::abs(workers[0].heartbeat_at - unix_time()) < 5.0);
      CHECK(workers[0].heartbeat_at >= first - 0.01);  // the update moved it forward (read-back shift aside)
    }
    CHECK(workers[0].state == "stopped");
  }
}

TEST_CASE("a transaction that throws writes nothing") {
  const std::string dir = test::temp_folder("store_rollback");
  for (const auto backend : test::all_backends()) {
    CAPTURE(test::backend_name(backend));
    auto store = create_store(test::study_address(backend, dir, "rollback"));
    CHECK_THROWS_AS(store->transaction([&] {
      store->add_trial(sample_trial());
      store->set_meta("k", "v");
      throw InputError("bad input halfway");
    }),
                    InputError);
    CHECK(store->trials().empty());
    CHECK_FALSE(store->meta("k").has_value());
    // Nested transactions join the outer one.
    store->transaction([&] {
      store->add_trial(sample_trial());
      store->transaction([&] { store->add_trial(sample_trial()); });
    });
    CHECK(store->trials().size() == 2);
  }
}

// The PostgreSQL store saves round trips: pending_trials() in a transaction brings next_finish_seq() along (kept
// until the transaction writes a trial), add_trial picks its id in the INSERT, and the open reads the meta entries
// Study::open needs (each handed out once, before any other use). Reads must still see every write.
TEST_CASE("reads see the transaction's own writes and other processes' later ones") {
  const std::string dir = test::temp_folder("store_read_your_writes");
  for (const auto backend : test::all_backends()) {
    CAPTURE(test::backend_name(backend));
    const std::string address = test::study_address(backend, dir, "read_your_writes");
    {
      auto store = create_store(address, {{store_key::kConfig, "v1"}, {store_key::kIdentity, "i1"}});
      TrialRecord p = sample_trial();
      p.state = TrialState::Pending;
      p.cost = std::nan("");
      p.finish_seq = -1;
      store->transaction([&] {
        CHECK(store->pending_trials().empty());
        CHECK(store->next_finish_seq() == 0);
        CHECK(store->add_trial(p) == 0);
        CHECK(store->add_trial(p) == 1);
        const auto pending = store->pending_trials();
        REQUIRE(pending.size() == 2);
        CHECK(store->next_finish_seq() == 0);
        TrialRecord done = pending[1];
        done.state = TrialState::Complete;
        done.cost = 1.5;
        done.finish_seq = store->next_finish_seq();
        store->update_trial(done);
        CHECK(store->next_finish_seq() == 1);
        CHECK(store->pending_trials().size() == 1);
        TrialRecord c = sample_trial();
        c.finish_seq = store->next_finish_seq();
        CHECK(store->add_trial(c) == 2);
        CHECK(store->next_finish_seq() == 2);
        CHECK(store->pending_trials().size() == 1);
      });
      CHECK(store->next_finish_seq() == 2);
    }
    auto a = open_store(address);
    auto b = open_store(address);
    b->transaction([&] { b->set_meta(store_key::kConfig, "v2"); });
    (void)a->meta(store_key::kConfig);  // PostgreSQL: the value read with the open, as if read then
    CHECK(a->meta(store_key::kConfig).value() == "v2");  // any later read is fresh
    auto c = open_store(address);
    b->transaction([&] { b->set_meta(store_key::kIdentity, "i2"); });
    CHECK(c->trials().size() == 3);  // another use forgets what the open read
    CHECK(c->meta(store_key::kIdentity).value() == "i2");
    CHECK(c->meta(store_key::kConfig).value() == "v2");
    c->transaction([&] { CHECK(c->meta(store_key::kIdentity).value() == "i2"); });
  }
}

TEST_CASE("schema version: a store written by a newer varbo is a clear error naming the study") {
  const std::string dir = test::temp_folder("store_schema");
  for (const auto backend : test::all_backends()) {
    CAPTURE(test::backend_name(backend));
    const std::string file = test::study_address(backend, dir, "newer");
    create_store(file);
    set_schema_version(file, "99");
    const std::string msg = open_error(file);
    CHECK(msg.find(file.substr(file.rfind('/') + 1)) != std::string::npos);  // the file, or the study's name
    CHECK(msg.find("newer varbo") != std::string::npos);
    CHECK(msg.find("schema version 99") != std::string::npos);
  }
}

TEST_CASE("schema version: a damaged version entry ('2abc', ' 2', '') is a corrupt store, not version 2") {
  const std::string dir = test::temp_folder("store_schema_text");
  for (const auto backend : test::all_backends()) {
    CAPTURE(test::backend_name(backend));
    int k = 0;
    for (const std::string bad : {"2abc", " 2", "", "2.0", "0x2"}) {
      CAPTURE(bad);
      const std::string file = test::study_address(backend, dir, "damaged" + std::to_string(k++));
      create_store(file);
      set_schema_version(file, bad);
      const std::string msg = open_error(file);  // stoi read "2abc" and " 2" as 2 and opened the store
      CHECK(msg.find("corrupt varbo study") != std::string::npos);
      CHECK(msg.find("schema_version '" + bad + "'") != std::string::npos);
    }
  }
}

TEST_CASE("foreign files: not SQLite, someone else's SQLite database, missing file, a folder, existing file on "
          "create") {
  const std::string dir = test::temp_folder("store_foreign");
  const std::string text = dir + "/notes.db";
  std::ofstream(text) << "this is a text file, long enough to have a header of sorts..............................."
                         ".........................................................................\n";
  std::string msg = open_error(text);
  CHECK(msg.find(text) != std::string::npos);
  CHECK(msg.find("not a varbo study store") != std::string::npos);

  const std::string other = dir + "/other.db";
  exec_sql(other, "CREATE TABLE customers (name TEXT)");
  msg = open_error(other);
  CHECK(msg.find(other) != std::string::npos);
  CHECK(msg.find("not a varbo study store") != std::string::npos);

  const std::string wrong_format = dir + "/wrong.db";
  exec_sql(wrong_format, "CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT); INSERT INTO meta VALUES ('format', 'x')");
  CHECK(open_error(wrong_format).find("not a varbo study store") != std::string::npos);

  msg = open_error(dir + "/missing.db");
  CHECK(msg.find("no such study file") != std::string::npos);
  CHECK_FALSE(std::filesystem::exists(dir + "/missing.db"));  // opening never creates a file

  // A folder (e.g. a run folder given where its study file is meant): said so, naming the study inside it.
  const std::string run_folder = dir + "/run";
  std::filesystem::create_directories(run_folder);
  CHECK(open_error(run_folder).find("a folder, not a study file") != std::string::npos);
  std::filesystem::copy_file(other, run_folder + "/study.db");
  CHECK(open_error(run_folder).find("this run folder's study is " + run_folder + "/study.db") != std::string::npos);

  CHECK_THROWS_WITH_AS(create_sqlite_store(other), doctest::Contains("exists already"), InputError);

  // Names SQLite reads as an in-memory database or a URI: refused, and no file of that name is made.
  const auto cwd = std::filesystem::current_path();
  std::filesystem::current_path(dir);
  CHECK_THROWS_WITH_AS(create_store(":memory:", {}), doctest::Contains("in-memory database"), InputError);
  CHECK_THROWS_WITH_AS(open_store("file:x.db?mode=memory"), doctest::Contains("a URI"), InputError);
  CHECK_THROWS_WITH_AS(create_store("", {}), doctest::Contains("empty"), InputError);
  CHECK_FALSE(std::filesystem::exists(dir + "/:memory:"));
  create_store("./:memory:", {});  // the way out the message names
  CHECK(std::filesystem::exists(dir + "/:memory:"));
  std::filesystem::current_path(cwd);
}

TEST_CASE("trial states have stable names") {
  for (TrialState s : {TrialState::Pending, TrialState::Complete, TrialState::Failed, TrialState::Abandoned})
    CHECK(state_from_name(state_name(s)) == s);
  CHECK_THROWS_AS(state_from_name("done"), InputError);
}

TEST_CASE("retry_while_unreachable keeps trying until its limit, the last attempt at the limit") {
  // Red team, session 25: the doubled wait that would overshoot the limit ended the retries early: with
  // `--reconnect-timeout 3` a worker gave up after 1.5 s (attempts at 0, 0.5, 1.5 s).
  set_log_level(LogLevel::Error);  // the retry warnings
  int attempts = 0;
  const auto t0 = std::chrono::steady_clock::now();
  CHECK_THROWS_AS(retry_while_unreachable(1.2, "test", {},
                                          [&]() -> int {
                                            ++attempts;
                                            throw StoreConnectionError("unreachable");
                                          }),
                  StoreConnectionError);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  set_log_level(LogLevel::Info);
  CHECK(seconds >= 1.15);  // waits 0.5 then the 0.7 left (not 0.5 and give up)
  CHECK(seconds < 3.0);
  CHECK(attempts == 3);
  int calls = 0;
  CHECK(retry_while_unreachable(5.0, "test", {}, [&] { return ++calls == 2 ? 7 : throw StoreConnectionError("once"); }) == 7);
}

// Snapshots instead of replays (docs/studies.md, "Snapshots"): a study driven one process at a time —
// every ask and every tell on a freshly opened Study, as `varbo suggest` / `varbo observe` do — continues from
// the saved algorithm state, replays nothing, and gives bit-for-bit the trials of an uninterrupted `varbo run`.
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <sstream>

#include "process.hpp"
#include "study_helpers.hpp"
#include "varbo/errors.hpp"
#include "varbo/store.hpp"
#include "varbo/study_api.hpp"
#include "varbo_test.hpp"

using namespace varbo;

namespace {

struct Case {
  const char* name;
  const char* algorithm;
  int budget;
};

// Branin (noise-free): bo fits a GP (or a VHGP) at every trial after the design; rssgd fits its critic at every
// update.
// The bo cases cover the default trust region (a region with state), the box, and failed trials (the failure
// model).
const Case kCases[] = {
    {"bo", "{type: bo, initial_points: 4}", 12},  // the defaults: trust_region, gp with full_fit_growth
    {"bo_box", "{type: bo, initial_points: 4, region: box}", 11},
    {"bo_vhgp", "{type: bo, initial_points: 4, surrogate: vhgp}", 10},  // vhgp_state.cpp
    // kern15: the gp's kernel chosen among candidates at each full fit is state too (gp_state.cpp).
    {"bo_kernel_candidates",
     "{type: bo, initial_points: 4, surrogate: {type: gp, kernel_candidates: [matern52_ard, se_ard]}}", 12},
    // A trust region that collapses after two failures and restarts afresh (a new design, a model of the new
    // points): the fresh-start counters are part of the state.
    {"bo_fresh_start",
     "{type: bo, initial_points: 3, region: {type: trust_region, restart_center: new_points, failure_tolerance: 1, "
     "length_min: 0.3}}",
     16},
    // The same with the final refinement on the model of the incumbent's attempt: its bounds are state too.
    {"bo_fresh_start_attempt_model",
     "{type: bo, initial_points: 3, refine_last: 4, refine_model: attempt, region: {type: trust_region, "
     "failure_tolerance: 1, length_min: 0.3}}",
     16},
    // fail14: the trust region's forced failures and bo's limited trials / jumped points are state too (with
    // failures where x1 > 8).
    {"bo_feasible_region",
     "{type: bo, initial_points: 4, failure_model: {feasible_region: both, feasible_shrink: halve, feasible_margin: 1, "
     "boundary_jump: edge}}",
     16},
    // fail15: a new attempt anchored at a probe (bo's follow_anchor, the trust region's anchor; the rule acts at
    // trial 9 here) is state too.
    {"bo_follow_probe",
     "{type: bo, initial_points: 4, failure_model: {follow_probe: 1, follow_distance: 0.1, follow_block: 0, "
     "follow_separated: false}}",
     16},
    // Session 25: random points are drawn in the region's box, which is the unit cube before the region's first
    // update; a restored trust region rebuilt a box of side 0.8 there (a random phase, initial_points: 0).
    {"bo_random_phase", "{type: bo, initial_points: 0, phases: [{evaluations: 4, random: true}, {acquisition: ei}]}",
     10},
    {"cma_es", "{type: cma_es}", 16},
    {"random", "{type: random}", 7},
    {"rssgd", "{type: rssgd, min_local_points: 3, critic: {type: gp}}", 10},
};

std::string yaml_of(const Case& c) {
  return std::string("task: {type: branin}\nbudget: ") + std::to_string(c.budget) + "\nseed: 11\nalgorithm: " +
         c.algorithm + "\n";
}

/// The evaluation `varbo run` makes of trial `index` (same task noise stream), failing where x1 > 8 so that
/// failed trials are part of the sequence.
Evaluation evaluate(Study& s, Index index, const Vec& theta) {
  Rng rng = Rng(s.config().seed).stream(0x7a5c).stream(static_cast<std::uint64_t>(index));
  Evaluation e = s.task().evaluate(theta, rng);
  if (theta[0] > 8.0) {
    e.ok = false;
    e.error = "fails where x1 > 8";
  }
  return e;
}

/// The study `yaml` run uninterrupted for `budget` trials in `dir`/ref.db, and the same study in
/// `dir`/s.db stopped after `done` trials: returns the reference run's trial positions x, in order.
std::vector<Vec> reference_and_partial(const std::string& dir, const std::string& yaml, Index budget, Index done) {
  std::vector<Vec> expected;
  {
    Study a = Study::create_from_yaml(dir + "/ref.db", yaml);
    for (Index i = 0; i < budget; ++i) {
      const auto t = a.ask().at(0);
      expected.push_back(t.x);
      a.record(t.id, evaluate(a, i, t.theta), 0.0);
    }
  }
  Study s = Study::create_from_yaml(dir + "/s.db", yaml);
  for (Index i = 0; i < done; ++i) {
    const auto t = s.ask().at(0);
    s.record(t.id, evaluate(s, i, t.theta), 0.0);
  }
  return expected;
}

}  // namespace

TEST_CASE("snapshots: one process per ask and per tell gives the uninterrupted run's trials, replaying nothing") {
  const std::string dir = test::temp_folder("snapshots");
  for (const Case& c : kCases) {
    const std::string name = c.name;
    CAPTURE(name);
    // Uninterrupted: one Study kept open, as `varbo run` does.
    std::vector<TrialRecord> straight;
    {
      Study a = Study::create_from_yaml(dir + "/" + c.name + "_a.db", yaml_of(c));
      for (Index i = 0; i < c.budget; ++i) {
        const TrialRecord t = a.ask().at(0);
        a.record(t.id, evaluate(a, i, t.theta), 0.0);
      }
      straight = a.trials();
    }
    if (name == "bo_fresh_start") {  // the case is only a test of fresh starts if one happened
      Index restarts = 0;
      for (const TrialRecord& t : straight) restarts += t.phase == "restart";
      CHECK(restarts >= 3);
    }
    // One fresh Study per call.
    const std::string db = dir + "/" + c.name + "_b.db";
    Study::create_from_yaml(db, yaml_of(c));
    Index replayed = 0;
    for (Index i = 0; i < c.budget; ++i) {
      TrialRecord t;
      {
        Study s = Study::open(db);
        t = s.ask().at(0);
        replayed += s.replayed();
      }
      Study s = Study::open(db);
      s.record(t.id, evaluate(s, i, t.theta), 0.0);
    }
    CHECK(replayed == 0);  // every ask continued from a saved state
    Study b = Study::open(db);
    CHECK(b.ask().empty());  // budget spent, and found before any model work
    CHECK(b.replayed() == 0);
    const std::vector<TrialRecord> stepped = b.trials();
    REQUIRE(stepped.size() == straight.size());
    for (std::size_t i = 0; i < straight.size(); ++i) {
      CAPTURE(i);
      CHECK(stepped[i].x == straight[i].x);  // bit-identical
      CHECK(stepped[i].state == straight[i].state);
      if (straight[i].state == TrialState::Complete) CHECK(stepped[i].cost == straight[i].cost);
    }
    // A full replay agrees with the trials and with every saved state.
    const VerifyReport v = b.verify();
    CHECK(v.divergence == "");
    CHECK(v.replayed == c.budget);
    CHECK(v.states_compared >= 1);
    CHECK(test::run({VARBO_EXE, "study", "verify", db}).exit_code == 0);
  }
}

TEST_CASE("snapshots: a run stopped and resumed continues from the saved state, equal to the uninterrupted run") {
  const std::string dir = test::temp_folder("snapshots_run");
  const std::string yaml = "task: {type: branin}\nbudget: 12\nseed: 3\nalgorithm: {type: bo, initial_points: 4}\n";
  RunOverrides full;
  full.output = dir + "/full";
  test::run_yaml(yaml, test::registry(), full);
  RunOverrides part;
  part.output = dir + "/part";
  part.budget = 7;
  test::run_yaml(yaml, test::registry(), part);
  RunOverrides resume = part;
  resume.budget = 12;
  resume.resume = true;
  test::run_yaml(yaml, test::registry(), resume);
  Study p = Study::open(dir + "/part/study.db");
  Study f = Study::open(dir + "/full/study.db");
  const auto a = p.trials(), b = f.trials();
  REQUIRE(a.size() == b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    CHECK(a[i].x == b[i].x);
    CHECK(a[i].cost == b[i].cost);
  }
  CHECK(p.verify().divergence == "");
  CHECK(f.verify().divergence == "");
}

TEST_CASE("snapshots: a corrupt saved state falls back to replay with a warning, same trials") {
  const std::string dir = test::temp_folder("snapshots_corrupt");
  const std::string yaml = "task: {type: branin}\nbudget: 8\nseed: 6\nalgorithm: {type: bo, initial_points: 4}\n";
  const std::string db = dir + "/s.db";
  const std::vector<Vec> expected = reference_and_partial(dir, yaml, 8, 6);
  {
    auto store = open_sqlite_store(db);
    store->transaction([&] {
      AlgorithmSnapshot bad;  // the newest state reaching furthest, but unreadable
      bad.finished = 6;
      bad.state = "{told: 6, fits: x}";
      store->add_algorithm_state(bad);
    });
  }
  Study s = Study::open(db);
  for (Index i = 6; i < 8; ++i) {
    const auto t = s.ask().at(0);
    CHECK(t.x == expected[static_cast<std::size_t>(i)]);
    s.record(t.id, evaluate(s, i, t.theta), 0.0);
  }
  CHECK(s.replayed() == 6);  // the corrupt state was not used: a full replay
  const VerifyReport v = s.verify();
  CHECK(v.divergence.find("differs from the replayed one") != std::string::npos);  // the planted state
  CHECK(test::run({VARBO_EXE, "study", "verify", db}).exit_code == 1);
}

namespace {
/// A state text as versions before vectors-as-one-scalar wrote it: every run of numbers a YAML list, in nested
/// component states too (they are YAML texts held as strings).
YAML::Node list_form(const YAML::Node& n, bool& changed) {
  if (n.IsMap()) {
    YAML::Node out(YAML::NodeType::Map);
    for (const auto& kv : n) {
      const std::string key = kv.first.Scalar();
      out[key] = key == "note" || key == "region_state" ? kv.second : list_form(kv.second, changed);
    }
    return out;
  }
  if (n.IsSequence()) {
    YAML::Node out(YAML::NodeType::Sequence);
    for (const auto& e : n) out.push_back(list_form(e, changed));
    return out;
  }
  if (!n.IsScalar()) return n;
  const std::string& s = n.Scalar();
  if (!s.empty() && s.front() == '{') {
    YAML::Emitter em;
    em << YAML::Flow << list_form(YAML::Load(s), changed);
    return YAML::Node(std::string(em.c_str()));
  }
  if (s.find(' ') == std::string::npos) return n;
  YAML::Node seq(YAML::NodeType::Sequence);
  std::stringstream words(s);
  for (std::string w; words >> w;) {
    char* end = nullptr;
    std::strtod(w.c_str(), &end);
    if (*end != '\0') return n;  // not a run of numbers
    seq.push_back(w);
  }
  changed = true;
  return seq;
}
}  // namespace

TEST_CASE("snapshots: a state saved in the list form of earlier versions is restored, and verify accepts it") {
  const std::string dir = test::temp_folder("snapshots_list_form");
  const std::string yaml = "task: {type: branin}\nbudget: 10\nseed: 6\nalgorithm: {type: bo, initial_points: 4}\n";
  const std::string db = dir + "/s.db";
  const std::vector<Vec> expected = reference_and_partial(dir, yaml, 10, 7);
  {
    // The same states again, newest, in the list form: the next process restores one of them.
    auto store = open_sqlite_store(db);
    const std::vector<AlgorithmSnapshot> states = store->algorithm_states();
    REQUIRE(!states.empty());
    bool changed = false;
    store->transaction([&] {
      for (AlgorithmSnapshot s : states) {
        YAML::Emitter em;
        em << YAML::Flow << list_form(YAML::Load(s.state), changed);
        s.state = em.c_str();
        store->add_algorithm_state(s);
      }
    });
    REQUIRE(changed);
  }
  {
    // verify compares each stored state with the replay's: the list-form ones as this version saves them.
    Study v = Study::open(db);
    const VerifyReport r = v.verify();
    CHECK(r.divergence == "");
    CHECK(r.states_compared >= 2);
  }
  Study s = Study::open(db);
  for (Index i = 7; i < 10; ++i) {
    const auto t = s.ask().at(0);
    CHECK(t.x == expected[static_cast<std::size_t>(i)]);
    s.record(t.id, evaluate(s, i, t.theta), 0.0);
  }
  CHECK(s.replayed() == 0);  // restored from a list-form state, not replayed
}

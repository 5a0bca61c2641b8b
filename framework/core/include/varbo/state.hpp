#pragma once
// Snapshots of algorithm state, so that a study continues from its latest state instead of replaying every
// trial (docs/studies.md, "Snapshots"). Two optional capabilities, found with dynamic_cast (the framework names
// no concrete plugin, as with RunContinuation):
//
//   class MyAlgorithm final : public Algorithm, public AlgorithmState { ... };   // the algorithm
//   class MySurrogate final : public Surrogate, public ComponentState { ... };   // a component it owns
//
// An algorithm that does not offer AlgorithmState is rebuilt by replay, as before. The contract is exactness:
// restoring a saved state must give an object whose every later result is bit-for-bit that of the object that
// was saved (`varbo study verify` checks it against a full replay). Numbers are therefore written so that they
// read back exactly (StateMap).
#include <optional>
#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "varbo/algorithm.hpp"

namespace varbo {

/// A component whose results depend on earlier calls (warm-started fits, Markov chains kept between calls,
/// a region's success counters). Algorithms that snapshot treat a component without it as stateless, so a
/// component that carries state from call to call must offer it.
class ComponentState {
 public:
  virtual ~ComponentState();
  virtual std::string save_state() const = 0;
  /// Throws InputError on text it cannot read.
  virtual void restore_state(const std::string& state) = 0;
};

/// An algorithm that can save its state and continue from it.
class AlgorithmState {
 public:
  virtual ~AlgorithmState();
  /// The state after the calls so far, or nullopt when it cannot be saved now (e.g. a component without
  /// ComponentState that is not known to be stateless): the study then falls back to replay.
  virtual std::optional<std::string> save_state() const = 0;
  /// Called on a freshly built algorithm (same configuration and seed): `history` holds the observations the
  /// saved algorithm had been told, in the order told; the algorithm takes its data from there (the state
  /// text holds no trials). Throws InputError when the text cannot be read.
  virtual void restore_state(const std::string& state, const std::vector<Observation>& history) = 0;
};

/// The ComponentState of `component`, if it offers one.
template <class T>
const ComponentState* state_of(const T* component) {
  return dynamic_cast<const ComponentState*>(component);
}
template <class T>
ComponentState* state_of(T* component) {
  return dynamic_cast<ComponentState*>(component);
}

/// A map of named values written as YAML, numbers in a form that reads back exactly (17 significant digits).
class StateMap {
 public:
  StateMap();
  /// Parses `text`; `what` names it in errors ("bo state", ...).
  static StateMap parse(const std::string& text, const std::string& what);
  std::string text() const;

  void put(const std::string& key, double v);
  void put_int(const std::string& key, long long v);
  void put(const std::string& key, bool v);
  void put(const std::string& key, const std::string& v);
  void put(const std::string& key, const char* v) { put(key, std::string(v)); }
  void put(const std::string& key, const Vec& v);
  void put(const std::string& key, const Mat& m);
  void put(const std::string& key, const StateMap& child);
  void put(const std::string& key, const std::vector<Vec>& rows);
  void put(const std::string& key, const ModelSnapshot& snapshot);

  bool has(const std::string& key) const;
  double real(const std::string& key) const;
  long long integer(const std::string& key) const;
  bool boolean(const std::string& key) const;
  std::string str(const std::string& key) const;
  Vec vec(const std::string& key) const;
  Mat mat(const std::string& key) const;
  StateMap map(const std::string& key) const;
  std::vector<Vec> rows(const std::string& key) const;
  ModelSnapshot model_snapshot(const std::string& key) const;

 private:
  StateMap(YAML::Node node, std::string what);
  YAML::Node at(const std::string& key) const;
  [[noreturn]] void fail(const std::string& key, const std::string& expected) const;
  YAML::Node node_;
  std::string what_;
};

}  // namespace varbo

#include "hyperparameter_map.hpp"
#include "varbo/numbers.hpp"

#include <algorithm>
#include <cmath>

namespace varbo::kernels {

namespace {

double finite_number(const ConfigNode& n) {
  if (!n.is_scalar()) n.fail("expected a number");
  const std::optional<double> v = parse_decimal(n.scalar());  // the C locale's '.', whatever the host's locale
  if (!v) n.fail("expected a number, got '" + n.scalar() + "'");
  if (!std::isfinite(*v)) n.fail("expected a finite number");
  return *v;
}

bool contains(const std::vector<std::string>& v, const std::string& s) { return std::find(v.begin(), v.end(), s) != v.end(); }

/// K[0], K[1], ... names for a key K that is not itself a name (0: none).
std::size_t indexed_count(const std::string& key, const std::vector<std::string>& names) {
  if (contains(names, key)) return 0;
  std::size_t count = 0;
  while (contains(names, key + "[" + std::to_string(count) + "]")) ++count;
  return count;
}

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

/// The keys a user may write: every name, indexed ones (lengthscale[0], ...) also by their base name.
std::vector<std::string> writable_keys(const std::vector<std::string>& names, const std::vector<std::string>& signed_names) {
  std::vector<std::string> keys;
  auto add = [&](const std::string& k) {
    if (!contains(keys, k)) keys.push_back(k);
  };
  for (const auto& n : names) {
    if (!n.empty() && n.back() == ']') {
      if (const std::size_t open = n.rfind('['); open != std::string::npos) add(n.substr(0, open));
    }
    add(n);
  }
  for (const auto& n : signed_names) add(n);
  return keys;
}

}  // namespace

Hyperparameters parse_hyperparameter_map(const ConfigNode& node, const std::vector<std::string>& names,
                                         const std::vector<std::string>& signed_names) {
  Hyperparameters h;
  if (!node.defined()) return h;
  if (!node.is_map()) node.fail("expected a map of hyperparameter names to values");
  auto add = [&](const std::string& name, const ConfigNode& n) {
    const double v = finite_number(n);
    if (!contains(signed_names, name) && !(v > 0)) n.fail("expected a positive value for " + name);
    h.push_back({name, v});
  };
  for (const auto& key : node.keys()) {
    const ConfigNode v = node.child(key);
    const std::size_t count = indexed_count(key, names);
    if (count == 0 && !contains(names, key) && !contains(signed_names, key)) {
      // Named here, before the value is read: `lengthscales: [..]` said "expected a number" (the list's shape).
      const std::vector<std::string> keys = writable_keys(names, signed_names);
      const std::string near = closest_match(key, keys);
      v.fail("unknown hyperparameter '" + key + "'; known: " + join(keys) +
             (near.empty() ? "" : "; did you mean '" + near + "'?"));
    }
    if (count > 0 && v.is_sequence()) {
      if (v.size() != count) {
        // The lengthscales of an ARD kernel (lengthscale, lengthscale_f, terms[0].lengthscale, ...).
        const bool per_dimension = ends_with(key, "lengthscale") || key.find("lengthscale_") != std::string::npos;
        v.fail("expected " + std::to_string(count) +
               (per_dimension ? " lengthscales (one per dimension)" : " values for " + key) + ", got " +
               std::to_string(v.size()));
      }
      for (std::size_t i = 0; i < v.size(); ++i) add(key + "[" + std::to_string(i) + "]", v.item(i));
    } else if (count > 0) {
      for (std::size_t i = 0; i < count; ++i) add(key + "[" + std::to_string(i) + "]", v);
    } else {
      add(key, v);
    }
  }
  return h;
}

}  // namespace varbo::kernels

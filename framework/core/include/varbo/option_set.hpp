#pragma once
// Options bound to the fields of a settings struct, so that each default is written once.
//
// In the spirit of Ceres' Solver::Options: the struct's member initializers ARE the defaults. A bound option
// takes its default from a default-constructed struct, and one call fills a struct from validated Options:
//
//   struct EiSettings { double xi = 0.0; int gh_nodes = 45; };
//   const varbo::OptionSet<EiSettings> ei_options{
//       varbo::opt::real("xi", &EiSettings::xi, "exploration ξ").at_least(0),
//       varbo::opt::integer("gh_nodes", &EiSettings::gh_nodes, "Gauss–Hermite nodes").at_least(1)};
//   make_component<Acquisition>("ei", "...", ei_options.specs(), [](const Options& o, const BuildContext&) {
//     const EiSettings s = ei_options.read(o);  ...
//
// The specs are made by the same opt:: builders as unbound ones, so --describe, config.resolved.yaml and
// every validation message are exactly those of `opt::real("xi", 0.0, ...)`. Unbound specs (components,
// maps, options read by hand) can sit in the same OptionSet; read() skips them.
//
// Field types: bool; any integer type (read through `long`, refused with file:line:col when the value does
// not fit the field); double; std::string (empty = no default); a choice into std::string or into an enum
// (or a bool) through a {name, value} mapping; std::vector<double> (empty = no default); and std::optional of a real,
// an integer or a list (nullopt = no default) for options whose absence means something. A field of a member
// struct is bound with opt::nested(&Outer::inner, &Inner::field).
#include <functional>
#include <initializer_list>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>
#include "varbo/options.hpp"

namespace varbo {

/// One declared option and, when bound, how to copy its validated value into a field of S.
template <class S>
class BoundOption {
 public:
  using Reader = std::function<void(const Options&, S&)>;
  /// An unbound option (a component, a map, or one the factory reads by hand).
  BoundOption(OptionSpec spec) : spec_(std::move(spec)) {}  // NOLINT(google-explicit-constructor): lists mix both
  BoundOption(OptionSpec spec, Reader reader) : spec_(std::move(spec)), reader_(std::move(reader)) {}

  BoundOption& at_least(double v) { spec_.at_least(v); return *this; }
  BoundOption& above(double v) { spec_.above(v); return *this; }
  BoundOption& at_most(double v) { spec_.at_most(v); return *this; }
  BoundOption& below(double v) { spec_.below(v); return *this; }
  /// Required: the user must give it, so the field's value is not a default (none is shown or used).
  BoundOption& must() { spec_.must(); spec_.default_yaml.clear(); return *this; }
  /// No declared default: unset, the option stays out of the resolved configuration and its field keeps the value
  /// the component decides (e.g. by kernel), so a stored study reopens as it ran even after that rule changes;
  /// given, it is read as usual (gp's min_noise_std and noise_test_level, bo's replicate_design).
  BoundOption& when_given() { spec_.default_yaml.clear(); return *this; }

  const OptionSpec& spec() const { return spec_; }
  bool bound() const { return static_cast<bool>(reader_); }
  /// Copies the value into `s` when the option has one (given or defaulted); leaves the field otherwise.
  void read(const Options& o, S& s) const {
    if (!reader_) return;
    if (!o.declared(spec_.name))
      throw std::logic_error("option '" + spec_.name + "' is bound to a field but was not validated with these specs");
    if (o.is_set(spec_.name)) reader_(o, s);
  }

 private:
  OptionSpec spec_;
  Reader reader_;
};

/// The options of one component and the settings struct they fill.
template <class S>
class OptionSet {
 public:
  OptionSet(std::initializer_list<BoundOption<S>> options) : options_(options) {}
  explicit OptionSet(std::vector<BoundOption<S>> options) : options_(std::move(options)) {}

  OptionSet& add(BoundOption<S> option) {
    options_.push_back(std::move(option));
    return *this;
  }
  /// The declarations, for make_component / validate_options / --describe.
  std::vector<OptionSpec> specs() const {
    std::vector<OptionSpec> out;
    out.reserve(options_.size());
    for (const auto& b : options_) out.push_back(b.spec());
    return out;
  }
  /// A default-constructed S with every bound option's value copied in.
  S read(const Options& o) const {
    S s{};
    read_into(o, s);
    return s;
  }
  /// Fills the bound fields of an existing S (e.g. one whose other fields come from the BuildContext).
  void read_into(const Options& o, S& s) const {
    for (const auto& b : options_) b.read(o, s);
  }
  const std::vector<BoundOption<S>>& options() const { return options_; }

 private:
  std::vector<BoundOption<S>> options_;
};

namespace detail {
/// "[0.1, 0.2]" with the same number format as opt::real's default text; "" for an empty list.
std::string reals_yaml(const std::vector<double>& values);

template <class I>
I checked_integer(const Options& o, const std::string& name) {
  const long v = o.integer(name);
  if (!std::in_range<I>(v))
    o.node(name).fail("expected an integer that fits the setting (" + std::to_string(std::numeric_limits<I>::min()) +
                      " to " + std::to_string(std::numeric_limits<I>::max()) + "), got " + std::to_string(v));
  return static_cast<I>(v);
}

/// What a builder binds to: a member pointer `T S::*`, or a field of a member struct (opt::nested).
template <class F>
struct field_traits {};
template <class S, class T>
struct field_traits<T S::*> {
  using settings = S;
  using type = T;
  static T& get(S& s, T S::*f) { return s.*f; }
};
}  // namespace detail

/// A field of a struct member of S, e.g. opt::nested(&MultistartSettings::local, &LocalSettings::xtol_rel).
/// Its default is the value in S{} (so an outer struct may give an inner struct other defaults).
template <class S, class M, class T>
struct NestedField {
  M S::*outer;
  T M::*inner;
};

namespace detail {
template <class S, class M, class T>
struct field_traits<NestedField<S, M, T>> {
  using settings = S;
  using type = T;
  static T& get(S& s, const NestedField<S, M, T>& f) { return s.*(f.outer).*(f.inner); }
};

template <class F>
using settings_of = typename field_traits<F>::settings;
template <class F>
using field_type = typename field_traits<F>::type;
template <class F>
field_type<F> default_of(const F& f) {
  settings_of<F> s{};
  return field_traits<F>::get(s, f);
}
template <class F>
field_type<F>& field_of(settings_of<F>& s, const F& f) {
  return field_traits<F>::get(s, f);
}

template <class I>
constexpr bool is_setting_integer = std::is_integral_v<I> && !std::is_same_v<I, bool>;
template <class T>
struct optional_integer : std::false_type {};
template <class I>
struct optional_integer<std::optional<I>> : std::bool_constant<is_setting_integer<I>> {};

// enable_if conditions on the field's type (substitution fails for anything that is not a field).
template <class F, class T>
using if_field = std::enable_if_t<std::is_same_v<field_type<F>, T>, int>;
template <class F>
using if_integer_field = std::enable_if_t<is_setting_integer<field_type<F>>, int>;
template <class F>
using if_optional_integer_field = std::enable_if_t<optional_integer<field_type<F>>::value, int>;
template <class F>
using if_mapped_field = std::enable_if_t<std::is_enum_v<field_type<F>> || std::is_same_v<field_type<F>, bool>, int>;
}  // namespace detail

/// Bound builders: the default is the field's value in a default-constructed settings struct.
namespace opt {

template <class S, class M, class T>
NestedField<S, M, T> nested(M S::*outer, T M::*inner) {
  return {outer, inner};
}

template <class F, detail::if_field<F, bool> = 0>
BoundOption<detail::settings_of<F>> boolean(std::string name, F field, std::string description) {
  const std::string key = name;
  return {boolean(std::move(name), detail::default_of(field), std::move(description)),
          [key, field](const Options& o, detail::settings_of<F>& s) { detail::field_of(s, field) = o.boolean(key); }};
}

/// Any integer field (int, long, Index, std::size_t, ...): read through `long`; a value that does not fit
/// the field is refused at its position in the config.
template <class F, detail::if_integer_field<F> = 0>
BoundOption<detail::settings_of<F>> integer(std::string name, F field, std::string description) {
  using I = detail::field_type<F>;
  const std::string key = name;
  return {integer(std::move(name), static_cast<long>(detail::default_of(field)), std::move(description)),
          [key, field](const Options& o, detail::settings_of<F>& s) {
            detail::field_of(s, field) = detail::checked_integer<I>(o, key);
          }};
}

/// An integer whose absence means something (nullopt in S{}: no default).
template <class F, detail::if_optional_integer_field<F> = 0>
BoundOption<detail::settings_of<F>> integer(std::string name, F field, std::string description) {
  using I = typename detail::field_type<F>::value_type;
  const std::string key = name;
  const std::optional<I> def = detail::default_of(field);
  OptionSpec spec = integer(std::move(name), static_cast<long>(def.value_or(0)), std::move(description));
  if (!def) spec.default_yaml.clear();
  return {std::move(spec), [key, field](const Options& o, detail::settings_of<F>& s) {
            detail::field_of(s, field) = detail::checked_integer<I>(o, key);
          }};
}

template <class F, detail::if_field<F, double> = 0>
BoundOption<detail::settings_of<F>> real(std::string name, F field, std::string description) {
  const std::string key = name;
  return {real(std::move(name), detail::default_of(field), std::move(description)),
          [key, field](const Options& o, detail::settings_of<F>& s) { detail::field_of(s, field) = o.real(key); }};
}

/// A real whose absence means something (nullopt in S{}: no default).
template <class F, detail::if_field<F, std::optional<double>> = 0>
BoundOption<detail::settings_of<F>> real(std::string name, F field, std::string description) {
  const std::string key = name;
  const std::optional<double> def = detail::default_of(field);
  OptionSpec spec = real(std::move(name), def.value_or(0.0), std::move(description));
  if (!def) spec.default_yaml.clear();
  return {std::move(spec),
          [key, field](const Options& o, detail::settings_of<F>& s) { detail::field_of(s, field) = o.real(key); }};
}

/// An empty string in S{} means no default (the option is unset unless given), as with opt::string(name, "").
template <class F, detail::if_field<F, std::string> = 0>
BoundOption<detail::settings_of<F>> string(std::string name, F field, std::string description) {
  const std::string key = name;
  return {string(std::move(name), detail::default_of(field), std::move(description)),
          [key, field](const Options& o, detail::settings_of<F>& s) { detail::field_of(s, field) = o.str(key); }};
}

/// A choice read into a std::string; its default (the field's value in S{}) must be one of `choices`.
template <class F, detail::if_field<F, std::string> = 0>
BoundOption<detail::settings_of<F>> choice(std::string name, F field, std::vector<std::string> choices,
                                           std::string description) {
  const std::string key = name;
  const std::string def = detail::default_of(field);
  bool known = def.empty();
  for (const auto& c : choices) known = known || c == def;
  if (!known) throw std::logic_error("option '" + key + "': the field's default '" + def + "' is not one of its choices");
  return {choice(std::move(name), def, std::move(choices), std::move(description)),
          [key, field](const Options& o, detail::settings_of<F>& s) { detail::field_of(s, field) = o.str(key); }};
}

/// A choice read into an enum (or a bool): `mapping` gives each accepted name and its value, in the order
/// shown; the default is the name of the field's value in S{}.
template <class F, detail::if_mapped_field<F> = 0>
BoundOption<detail::settings_of<F>> choice(std::string name, F field,
                                           std::vector<std::pair<std::string, detail::field_type<F>>> mapping,
                                           std::string description) {
  const std::string key = name;
  const auto def = detail::default_of(field);
  std::vector<std::string> names;
  std::string def_name;
  for (const auto& [n, v] : mapping) {
    names.push_back(n);
    if (v == def && def_name.empty()) def_name = n;
  }
  if (def_name.empty())
    throw std::logic_error("option '" + key + "': the field's default value has no name in its choice mapping");
  return {choice(std::move(name), def_name, std::move(names), std::move(description)),
          [key, field, mapping](const Options& o, detail::settings_of<F>& s) {
            const std::string v = o.str(key);
            for (const auto& [n, e] : mapping)
              if (n == v) {
                detail::field_of(s, field) = e;
                return;
              }
            throw std::logic_error("option '" + key + "': validated choice '" + v + "' has no mapping");
          }};
}

/// An empty list in S{} means no default (unset unless given).
template <class F, detail::if_field<F, std::vector<double>> = 0>
BoundOption<detail::settings_of<F>> reals(std::string name, F field, std::string description) {
  const std::string key = name;
  return {reals(std::move(name), detail::reals_yaml(detail::default_of(field)), std::move(description)),
          [key, field](const Options& o, detail::settings_of<F>& s) { detail::field_of(s, field) = o.reals(key); }};
}

/// A list whose absence means something (nullopt in S{}: no default; a given [] is an empty list).
template <class F, detail::if_field<F, std::optional<std::vector<double>>> = 0>
BoundOption<detail::settings_of<F>> reals(std::string name, F field, std::string description) {
  const std::string key = name;
  const auto def = detail::default_of(field);
  std::string text = def ? detail::reals_yaml(*def) : std::string();
  if (def && def->empty()) text = "[]";
  return {reals(std::move(name), std::move(text), std::move(description)),
          [key, field](const Options& o, detail::settings_of<F>& s) { detail::field_of(s, field) = o.reals(key); }};
}

}  // namespace opt
}  // namespace varbo

#pragma once
/// \file Configuration keys declared once, beside the option field each one sets. A KeyTable of an
/// options struct holds, per key, its name, help, unit, range or allowed values and the field it
/// sets; the schema's KeySpec (specs(), with the default read from the struct's own default member
/// initialisers) and the application of validated settings to the struct (apply()) both derive
/// from that one declaration. Example (a double in [0, 1], an enum of named values):
///
///     KeyTable<MyOptions> t;
///     t.add("my.rate", [](auto& o) -> auto& { return o.rate; })
///         .range(0, 1).help("probability of ...");
///     t.add("my.mode", [](auto& o) -> auto& { return o.mode; })
///         .values({{"fast", Mode::kFast}, {"exact", Mode::kExact}}).help("...");
///     t.specs();          // KeySpecs: "my.rate" double default "0.5" (MyOptions{}.rate) ...
///     t.apply(settings, options);  // options.rate = 0.3 for settings {my.rate: "0.3"}

#include <array>
#include <deque>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "drops/experiment/config.hpp"

namespace drops::experiment {

/// The named values of an enum key (the schema's allowed list and the parser), in the order shown.
template <class T>
using Choices = std::vector<std::pair<std::string, T>>;

/// The field type of an "interval" key: [lower, upper], lower < upper.
using Interval = std::array<double, 2>;
/// The field type of a "names" key: distinct names among the key's allowed ones.
using Names = std::vector<std::string>;

/// The shortest text that reads back as v ("0.01", "1e-12", "300"). Thread-safe.
std::string key_text(double v);
/// v in decimal. Thread-safe.
std::string key_text(long long v);
/// The value of an enum key's setting `key` among `names` (index into names). Throws ConfigError
/// naming the key, the value and the allowed names when it is none of them.
std::size_t choice_index(const Settings& settings, const std::string& key,
                         const std::vector<std::string>& names);

/// The keys of one options struct, each declared once with the field it sets. Declaring is not
/// thread-safe; const members are.
template <class Options>
class KeyTable {
  struct Row {
    KeySpec spec;
    bool optional = false;  // default ""; an empty setting leaves the field as it is
    std::function<std::string(Options&)> text;  // the field's value as setting text (reads only)
    std::function<void(const Settings&, Options&)> set;
    // derived(): sets the field from the others when the setting is empty (after every set)
    std::function<void(Options&)> derive;
  };

 public:
  /// The declaration of one key, returned by add() to state its range, unit and help.
  template <class T>
  class Key {
   public:
    /// Numeric range [lo, hi] (inclusive) that validation enforces.
    Key& range(double lo, double hi) {
      row_->spec.min = lo;
      row_->spec.max = hi;
      return *this;
    }
    /// Physical unit, e.g. "m" ("-", the default, when none).
    Key& unit(std::string u) {
      row_->spec.unit = std::move(u);
      return *this;
    }
    /// The key's meaning, one line for the schema and docs/configuration.md.
    Key& help(std::string doc) {
      row_->spec.doc = std::move(doc);
      return *this;
    }
    /// Makes the key an enum of these named values (the allowed list, in this order, and how the
    /// field is parsed and its default named).
    Key& values(Choices<T> choices) {
      *choices_ = std::move(choices);
      row_->spec.type = "enum";
      row_->spec.allowed.clear();
      for (const auto& c : *choices_) row_->spec.allowed.push_back(c.first);
      return *this;
    }
    /// The names a "names" key (a Names field) may list.
    Key& allowed(std::vector<std::string> names) {
      row_->spec.allowed = std::move(names);
      return *this;
    }
    /// The schema's type name when it is not the field's (e.g. "enum" for a string whose allowed
    /// values a registry supplies).
    Key& type(std::string name) {
      row_->spec.type = std::move(name);
      return *this;
    }
    /// The default is "" and the help says what an empty value means (the field's own default,
    /// or derived()): an empty setting leaves the field as it is.
    Key& optional() {
      row_->optional = true;
      return *this;
    }
    /// Makes the key optional() with a default that follows other fields: an empty setting sets
    /// the field to rule(options) once every other key of the table is applied (e.g. a run's
    /// budget, a quarter of the total). rule must not read another derived field.
    template <class Rule>
    Key& derived(Rule rule) {
      row_->optional = true;
      row_->derive = [field = field_, rule](Options& o) {
        const T value = rule(static_cast<const Options&>(o));
        std::invoke(field, o) = value;
      };
      return *this;
    }
    /// The same value also goes to another field of the same type (e.g. two tolerances).
    template <class Field>
    Key& also(Field other) {
      row_->set = [set = std::move(row_->set), field = field_, other](const Settings& s,
                                                                      Options& o) {
        set(s, o);
        std::invoke(other, o) = std::invoke(field, o);
      };
      return *this;
    }

   private:
    friend class KeyTable;
    using Field = std::function<T&(Options&)>;
    Key(Row* row, Field field, std::shared_ptr<Choices<T>> choices)
        : row_(row), field_(std::move(field)), choices_(std::move(choices)) {}
    Row* row_;
    Field field_;
    std::shared_ptr<Choices<T>> choices_;
  };

  /// Declares `key`, which sets the field that `field` returns (a callable Options& -> T&, e.g.
  /// `[](auto& o) -> auto& { return o.model.rprop.tolerance; }`, or a pointer to member). T is
  /// bool, an integer type, a floating-point type, std::string, Interval, Names (with allowed()),
  /// std::optional of one of these (empty text = no value), or (with values()) any type. Its
  /// default is the field of a default-constructed Options (specs()). A key's name is unique in a
  /// schema: Registry refuses a task or algorithm that repeats one.
  template <class FieldFn>
  auto add(std::string key, FieldFn field) {
    using T = std::remove_reference_t<std::invoke_result_t<FieldFn, Options&>>;
    static_assert(!std::is_const_v<T>, "the field accessor must return a non-const reference");
    auto choices = std::make_shared<Choices<T>>();
    Row& row = rows_.emplace_back();
    row.spec.key = key;
    row.spec.unit = "-";
    row.spec.type = type_name<T>();
    typename Key<T>::Field get = [field](Options& o) -> T& { return std::invoke(field, o); };
    row.text = [field, choices](Options& o) { return to_text<T>(std::invoke(field, o), *choices); };
    row.set = [get, choices, key](const Settings& s, Options& o) {
      get(o) = parse<T>(s, key, *choices);
    };
    return Key<T>(&row, std::move(get), std::move(choices));
  }

  /// Appends the keys of `sub`, a table of a struct that `part` (a callable Options& -> Sub&)
  /// reaches inside Options; their defaults are then read from a default-constructed Options
  /// (e.g. a CMA-ES table inside the policy search's options, with the policy search's defaults).
  template <class Sub, class PartFn>
  KeyTable& include(const KeyTable<Sub>& sub, PartFn part) {
    for (const auto& r : sub.rows_) {
      Row& row = rows_.emplace_back();
      row.spec = r.spec;
      row.optional = r.optional;
      row.text = [text = r.text, part](Options& o) { return text(std::invoke(part, o)); };
      row.set = [set = r.set, part](const Settings& s, Options& o) {
        set(s, std::invoke(part, o));
      };
      if (r.derive)
        row.derive = [derive = r.derive, part](Options& o) { derive(std::invoke(part, o)); };
    }
    return *this;
  }

  /// The schema of the keys, in declaration order, with the defaults of `defaults` (an optional
  /// key's: ""). Thread-safe.
  std::vector<KeySpec> specs(const Options& defaults = Options()) const {
    std::vector<KeySpec> out;
    Options d = defaults;  // the field accessors take a non-const struct; they only read here
    for (const auto& r : rows_) {
      out.push_back(r.spec);
      out.back().default_value = r.optional ? "" : r.text(d);
    }
    return out;
  }

  /// Sets every declared field of `options` from validated settings (load_settings: every key of
  /// the table present), then the derived() fields whose setting is empty. Throws ConfigError
  /// naming the key for a value that does not convert, and std::out_of_range for a missing key.
  /// Thread-safe.
  void apply(const Settings& settings, Options& options) const {
    for (const auto& r : rows_)
      if (!r.optional || !settings.at(r.spec.key).empty()) r.set(settings, options);
    for (const auto& r : rows_)
      if (r.derive && settings.at(r.spec.key).empty()) r.derive(options);
  }

  /// A default-constructed Options with every declared field set from settings (apply()). Throws
  /// as apply(). Thread-safe.
  Options read(const Settings& settings) const {
    Options options;
    apply(settings, options);
    return options;
  }

 private:
  template <class>
  friend class KeyTable;

  template <class T>
  struct is_optional : std::false_type {};
  template <class U>
  struct is_optional<std::optional<U>> : std::true_type {};

  template <class T>
  static std::string type_name() {
    if constexpr (is_optional<T>::value)
      return type_name<typename T::value_type>();
    else if constexpr (std::is_same_v<T, Interval>)
      return "interval";
    else if constexpr (std::is_same_v<T, Names>)
      return "names";
    else if constexpr (std::is_same_v<T, bool>)
      return "bool";
    else if constexpr (std::is_integral_v<T>)
      return "int";
    else if constexpr (std::is_floating_point_v<T>)
      return "double";
    else if constexpr (std::is_same_v<T, std::string>)
      return "string";
    else
      return "enum";  // values() names them
  }

  template <class T>
  static std::string to_text(const T& v, const Choices<T>& choices) {
    if (!choices.empty() || std::is_enum_v<T>) {
      for (const auto& c : choices)
        if (c.second == v) return c.first;
      return "";  // a default that no name denotes (an enum declared without values())
    }
    if constexpr (is_optional<T>::value) {
      return v ? to_text<typename T::value_type>(*v, {}) : std::string();
    } else if constexpr (std::is_same_v<T, Interval>) {
      return "[" + key_text(v[0]) + ", " + key_text(v[1]) + "]";
    } else if constexpr (std::is_same_v<T, Names>) {
      std::string t;
      for (const auto& n : v) t += (t.empty() ? "" : ", ") + n;
      return "[" + t + "]";
    } else if constexpr (std::is_same_v<T, bool>)
      return v ? "true" : "false";
    else if constexpr (std::is_integral_v<T>)
      return key_text(static_cast<long long>(v));
    else if constexpr (std::is_floating_point_v<T>)
      return key_text(static_cast<double>(v));
    else if constexpr (std::is_same_v<T, std::string>)
      return v;
    else
      return "";
  }

  template <class T>
  static T parse(const Settings& s, const std::string& key, const Choices<T>& choices) {
    if (!choices.empty() || std::is_enum_v<T>) {
      std::vector<std::string> names;
      for (const auto& c : choices) names.push_back(c.first);
      return choices[choice_index(s, key, names)].second;
    }
    if constexpr (is_optional<T>::value) {
      if (s.at(key).empty()) return std::nullopt;
      return parse<typename T::value_type>(s, key, {});
    } else if constexpr (std::is_same_v<T, Interval>) {
      const std::vector<double> v = get_interval(s, key);
      return Interval{v[0], v[1]};
    } else if constexpr (std::is_same_v<T, Names>)
      return get_names(s, key);
    else if constexpr (std::is_same_v<T, bool>)
      return get_bool(s, key);
    else if constexpr (std::is_integral_v<T>)
      return static_cast<T>(get_int(s, key));
    else if constexpr (std::is_floating_point_v<T>)
      return static_cast<T>(get_double(s, key));
    else if constexpr (std::is_same_v<T, std::string>)
      return s.at(key);
    else
      return choices.at(0).second;  // not reached: choice_index threw
  }

  std::deque<Row> rows_;  // a deque: add() hands out pointers to its rows
};

}  // namespace drops::experiment

#pragma once
// Components by name (the base of every registry: forcefields/registry.hpp, core/registries.hpp):
// every force field, integrator, linear solver, action and constraint registers, in its own
// source file, its name, its keys with what each means, how to read its typed parameters (with
// their checks) from a ParameterSource, and how to build itself. Scene files read through these
// registries, and so will every other front end (Python dicts, SOFA .scn attributes): each one
// only implements ParameterSource.
//
// Registration (in the component's .cpp, at namespace scope):
//
//   const bool registered = ForceFieldRegistry::instance().add({
//       "MyField", "one line on what it is",
//       {{"stiffness", KeyType::Number, "N/m, >= 0", {}, /*required*/ true}, ...},
//       {},  // the other kinds of component it is built with ("linearSolver")
//       [](const ParameterSource& s) -> std::any { MyParameters p; ...; return p; },
//       [](const std::any& p, topology::Topology& t) -> std::unique_ptr<ForceField> {...}});
//
// The libraries are linked whole (CMake's WHOLE_ARCHIVE), so such a file needs nothing else to
// be found.
#include <any>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "cutsim/base/errors.hpp"
#include "cutsim/base/vec3.hpp"

namespace cutsim {

/// Where a component's parameters come from. Implementations report a problem with fail(key,
/// message), which must throw (an InvalidInput naming the file, the line and the key).
class ParameterSource {
 public:
  virtual ~ParameterSource();
  virtual bool has(std::string_view key) const = 0;
  /// The value of a present key, checked for its type: a finite number, an integer in [min, max],
  /// a boolean, a string.
  virtual double number(std::string_view key) const = 0;
  virtual long integer(std::string_view key, long min, long max) const = 0;
  virtual bool boolean(std::string_view key) const = 0;
  virtual std::string string(std::string_view key) const = 0;
  /// A file's name, as string(); a relative name is taken from where the parameters come from
  /// (a scene's folder), which this default does not know.
  virtual std::string file(std::string_view key) const { return string(key); }
  /// Fails at `key`; a key path "polyline/2" names an element inside a key's value, "" the
  /// component itself.
  [[noreturn]] virtual void fail(std::string_view key, const std::string& message) const = 0;

  // ---- structured values (timeline actions, constraints) ----
  /// An array of integers, each in [min, max].
  virtual std::vector<long> integers(std::string_view key, long min, long max) const = 0;
  /// An array of at least minCount arrays of `width` numbers each ([x, y, z] points: width 3).
  virtual std::vector<std::vector<double>> rows(std::string_view key, std::size_t width,
                                                std::size_t minCount) const = 0;
  /// A nested object, read as a source of its own (its keys are checked against `keys`).
  virtual std::unique_ptr<ParameterSource> object(
      std::string_view key, std::initializer_list<std::string_view> keys) const = 0;
  /// [x, y, z].
  virtual Vec3 vec3(std::string_view key) const = 0;
  /// At least minCount [x, y, z] points.
  virtual std::vector<Vec3> points(std::string_view key, std::size_t minCount) const = 0;
  /// [[xmin, ymin, zmin], [xmax, ymax, zmax]], min <= max.
  virtual std::pair<Vec3, Vec3> box(std::string_view key) const = 0;
  /// Exactly one of `keys` is present: which (fails naming them otherwise).
  std::string_view oneOf(std::initializer_list<std::string_view> keys) const;

  // ---- conveniences: the value if present, else the fallback ----
  double number(std::string_view key, double fallback) const {
    return has(key) ? number(key) : fallback;
  }
  double nonNegative(std::string_view key, double fallback) const;
  double positive(std::string_view key, double fallback) const;
  long integer(std::string_view key, long min, long max, long fallback) const {
    return has(key) ? integer(key, min, max) : fallback;
  }
  bool boolean(std::string_view key, bool fallback) const {
    return has(key) ? boolean(key) : fallback;
  }
  /// One of `choices` (the fallback when absent); anything else fails naming the choices.
  std::string choice(std::string_view key, std::string fallback,
                     std::initializer_list<std::string_view> choices) const;
  /// A required key: fails "missing key" when absent.
  void require(std::string_view key) const;
  /// Runs a parameter struct's validate(); an InvalidInput it throws is reported at the key its
  /// where() names (when that is one of this source's keys, else at the component).
  template <class Validate>
  void check(Validate&& validate) const {
    try {
      validate();
    } catch (const InvalidInput& e) {
      fail(e.where(), e.message());
    }
  }
};

/// Parameters given as plain values in code (a program's defaults, the study's methods, the
/// tests' harnesses): numbers, integers, booleans and strings by key. A component that asks for
/// a structured value (an array, a point, a box, an object) is refused, as is a value of the
/// wrong type; every problem is an InvalidInput at "WHERE: KEY: message".
class ScalarParameters final : public ParameterSource {
 public:
  using Value = std::variant<double, long, bool, std::string>;
  explicit ScalarParameters(std::string where,
                            std::map<std::string, Value, std::less<>> values = {})
      : where_(std::move(where)), values_(std::move(values)) {}
  bool has(std::string_view key) const override { return values_.count(key) > 0; }
  /// The keys given, sorted.
  std::vector<std::string> keys() const {
    std::vector<std::string> out;
    for (const auto& [k, v] : values_) out.push_back(k);
    return out;
  }
  double number(std::string_view key) const override;
  long integer(std::string_view key, long min, long max) const override;
  bool boolean(std::string_view key) const override;
  std::string string(std::string_view key) const override;
  [[noreturn]] void fail(std::string_view key, const std::string& message) const override;
  std::vector<long> integers(std::string_view key, long, long) const override { structured(key); }
  std::vector<std::vector<double>> rows(std::string_view key, std::size_t,
                                        std::size_t) const override {
    structured(key);
  }
  std::unique_ptr<ParameterSource> object(std::string_view key,
                                          std::initializer_list<std::string_view>) const override {
    structured(key);
  }
  Vec3 vec3(std::string_view key) const override { structured(key); }
  std::vector<Vec3> points(std::string_view key, std::size_t) const override { structured(key); }
  std::pair<Vec3, Vec3> box(std::string_view key) const override { structured(key); }

 private:
  const Value& value(std::string_view key) const;
  [[noreturn]] void structured(std::string_view key) const;
  std::string where_;
  std::map<std::string, Value, std::less<>> values_;
};

/// The kind of value a key takes, as a ParameterSource reads it: number(), integer(),
/// boolean(), choice(), string() (or file()), integers(), points(), rows(), box(), object(),
/// vec3() (Point: one [x, y, z]).
enum class KeyType {
  Number,
  Integer,
  Boolean,
  Choice,
  String,
  Integers,
  Points,
  Rows,
  Box,
  Object,
  Point
};
/// "number", "integer", "boolean", "choice", "string", "integers", "points", "rows", "box",
/// "object", "point".
const char* toString(KeyType type);

/// A key of a component: its name, the kind of value it takes, what it means (for messages and
/// `cutsim components`), the values of a choice (its default first), examples of a string's or
/// an example of an object's (as JSON), and whether it is required. The tests build every component
/// from values made after these declarations.
struct KeyInfo {
  std::string name;
  KeyType type;
  std::string what;
  std::vector<std::string> choices = {};
  bool required = false;
};

/// Refuses, as a scene refuses an unknown key, a key of `values` that `keys` does not declare
/// (InvalidInput at "WHERE: KEY: unknown key ...; expected one of: ...").
void requireDeclared(const ScalarParameters& values, const std::vector<KeyInfo>& keys);

/// The registry of one kind of component (a force field, an integrator, a linear solver).
template <class Product, class... BuildArgs>
class Registry {
 public:
  struct Entry {
    std::string name;
    std::string summary;
    std::vector<KeyInfo> keys;  ///< besides "type" (and "label" for force fields)
    /// The other kinds of component it is built with ("linearSolver" for implicit integrators).
    std::vector<std::string> uses;
    /// Reads and checks the typed parameters (a struct, held in the std::any).
    std::function<std::any(const ParameterSource&)> read;
    std::function<std::unique_ptr<Product>(const std::any&, BuildArgs...)> build;
    /// read() of plain values given in code, refusing a key the entry does not declare.
    std::any readValues(const ScalarParameters& values) const {
      requireDeclared(values, keys);
      return read(values);
    }
  };

  static Registry& instance() {
    static Registry registry;
    return registry;
  }
  /// Adds an entry; a second entry with the same name is a programming error (std::logic_error).
  bool add(Entry entry) {
    const std::string name = entry.name;
    if (!entries_.emplace(name, std::move(entry)).second)
      throw std::logic_error("component '" + name + "' registered twice");
    return true;
  }
  const Entry* find(std::string_view name) const {
    auto it = entries_.find(std::string(name));
    return it == entries_.end() ? nullptr : &it->second;
  }
  /// Every registered name, sorted.
  std::vector<std::string> names() const {
    std::vector<std::string> out;
    for (auto& [name, e] : entries_) out.push_back(name);
    return out;
  }
  const std::map<std::string, Entry>& entries() const { return entries_; }
  /// The other entries that have `key` (for "that key belongs to ..." messages).
  std::vector<std::string> ownersOf(std::string_view key) const {
    std::vector<std::string> out;
    for (auto& [name, e] : entries_)
      for (auto& k : e.keys)
        if (k.name == key) out.push_back(name);
    return out;
  }

 private:
  std::map<std::string, Entry> entries_;
};

}  // namespace cutsim

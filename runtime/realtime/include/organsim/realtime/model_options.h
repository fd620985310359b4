// The options of the deformation models. Each model owns its options: a
// struct of its own (multibeam::MultiBeamOptions, SpringModelOptions,
// fem::OrganFemOptions, …), kept in one ModelOptions under that struct's type,
// and the settings it takes by name from a command line or a script
// (ModelParameter, listed in its model_registry.h entry). Nothing outside a
// model's folder lists its options: the command line's --NAME options, the
// Python module's keywords and their help texts come from the parameters.
#pragma once

#include <cstddef>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <typeindex>
#include <typeinfo>

namespace organsim::realtime {

/// Every model's options, each under its own struct's type. A model reads its
/// own with of<ItsOptions>() (the struct's defaults where nobody set them); a
/// caller changes them with edit<ItsOptions>(). Copies are independent (a
/// copy shares an options struct until one of them edits it).
class ModelOptions {
 public:
  template <class Options>
  const Options& of() const {
    const auto found = entries_.find(std::type_index(typeid(Options)));
    if (found == entries_.end()) return defaults<Options>();
    return *static_cast<const Options*>(found->second.value.get());
  }

  template <class Options>
  Options& edit() {
    Entry& entry = entries_[std::type_index(typeid(Options))];
    if (!entry.value) {
      entry.value = std::make_shared<Options>();
      entry.clone = [](const void* options) -> std::shared_ptr<void> {
        return std::make_shared<Options>(*static_cast<const Options*>(options));
      };
    } else if (entry.value.use_count() > 1) {
      entry.value = entry.clone(entry.value.get());
    }
    return *static_cast<Options*>(entry.value.get());
  }

 private:
  template <class Options>
  static const Options& defaults() {
    static const Options options{};
    return options;
  }
  struct Entry {
    std::shared_ptr<void> value;
    std::shared_ptr<void> (*clone)(const void*) = nullptr;
  };
  std::map<std::type_index, Entry> entries_;
};

/// A parameter's value as set() takes it and get() gives it: a length in m, a
/// number, a count or a flag (0 or 1) in `number`; a choice's name in `text`.
struct ParameterValue {
  double number = 0.0;
  std::string_view text;
};

/// One setting of a model, given by name: `--NAME VALUE` on the command line
/// (lengths in mm there, converted to m as they are read), `NAME=VALUE` in the
/// Python module with '_' for '-' (lengths in m). Several models may take the
/// same name (the FEM models' --fixed-radius): one value then sets each.
struct ModelParameter {
  enum class Kind { length, number, count, choice, flag };
  const char* name;  ///< "region-threshold"
  Kind kind;
  const char* help;     ///< one line for --help; a length's help says nothing of its unit
  const char* choices;  ///< a choice's names, '|'-separated ("all|dynamic|fixed"); nullptr otherwise
  /// Writes `value` into `options`: "" when it did, else why the value is out
  /// of range (one line, naming no option).
  std::string (*set)(ModelOptions& options, const ParameterValue& value);
  /// The value `options` holds, as set() takes it (a choice's name is a
  /// static string).
  ParameterValue (*get)(const ModelOptions& options);
};

/// The `supports` setting every model takes (docs/supports.md): its help,
/// its choices, and how its value is read into and out of a model's flag.
inline constexpr const char* kSupportsHelp =
    "every model: also hold the organ on the supports the bake found in the CT (baked: a foundation on the FEM "
    "models' boundary, the mass-spring nodes and the beams' nodes, the matched force of the organ on them), or by the "
    "clamp alone (none; docs/supports.md)";
inline constexpr const char* kSupportsChoices = "none|baked";
inline std::string read_supports(const ParameterValue& value, bool& flag) {
  if (value.text != "none" && value.text != "baked") return "supports are none or baked";
  flag = value.text == "baked";
  return "";
}
inline ParameterValue supports_value(bool flag) { return {0.0, flag ? "baked" : "none"}; }

}  // namespace organsim::realtime

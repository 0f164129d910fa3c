// Plan power's design check: the control and the null settings, refused
// with the field that differs before any simulation.
#include "planning/plan_design.h"

#include <algorithm>
#include <exception>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "analysis/study/study_analysis.h"
#include "core/settings/settings_json.h"
#include "planning/plan_inputs.h"
#include "planning/undegraded_control.h"

namespace hapticlab::planning {

// Refused before any simulation: a protocol without a control, a null
// setting that is not a copy of the control, or a design that cannot take
// a participant count.
PlanDesign check_plan_design(const protocols::Protocol& protocol, const std::string& protocol_path,
                             const std::vector<int>& counts, std::uint64_t seed, const SimulatedStudyOptions& sim) {
  const struct {
    const std::string& protocol;
    std::uint64_t seed;
  } o{protocol_path, seed};
  std::set<std::string> null_settings;
  std::string control_name;
  std::vector<std::string> notes;
  {
    analysis::StudyAnalysis names;
    for (const auto& s : protocol.settings) names.settings.push_back(s.settings.name);
    try {
      analysis::choose_control(names, sim.analysis, analysis::kPlanControlRemedy);
    } catch (const std::exception& e) {
      throw std::runtime_error(o.protocol + ": " + e.what() +
                               "; plan power compares every setting with the control");
    }
    control_name = names.control;
    check_control_undegraded(protocol, names.control, o.protocol, "plan power");
    for (int n : counts) (void)resized_protocol(protocol, n, o.seed);
    // A null setting: the control's parameters under another name. Any
    // difference found for it is a false positive.
    auto parameters = [](const NamedSettings& s) {
      nlohmann::json j = settings_to_json(s);
      j.erase("name");
      j.erase("description");
      return j;
    };
    const auto control = std::find_if(protocol.settings.begin(), protocol.settings.end(),
                                      [&](const auto& s) { return s.settings.name == names.control; });
    const nlohmann::json control_parameters = parameters(control->settings);
    // Declared ones ("null_settings") must be copies: a null setting that
    // differs measures an effect, not the false-positive rate.
    for (const std::string& name : protocol.null_settings) {
      if (name == names.control)
        throw std::runtime_error(o.protocol + ": null_settings names '" + name + "', the control itself; a null "
                                 "setting is a copy of the control under another name");
      const nlohmann::json mine = parameters(protocol.settings[*protocol.find_setting(name)].settings);
      if (mine != control_parameters) {
        std::string field = "?";
        const nlohmann::json diff = nlohmann::json::diff(control_parameters, mine);
        if (!diff.empty()) {
          field = diff[0].value("path", "?");  // a JSON pointer, /translation/friction/enabled
          std::replace(field.begin(), field.end(), '/', '.');
          if (!field.empty() && field.front() == '.') field.erase(0, 1);
        }
        throw std::runtime_error(o.protocol + ": null_settings names '" + name + "', but it is not a copy of the "
                                 "control '" + names.control + "': it differs at " + field +
                                 " (a null setting has the control's parameters under another name)");
      }
      null_settings.insert(name);
    }
    // Undeclared copies are null settings too (nothing but the name differs), said so.
    for (const auto& s : protocol.settings)
      if (s.settings.name != names.control && !null_settings.count(s.settings.name) &&
          parameters(s.settings) == control_parameters) {
        null_settings.insert(s.settings.name);
        notes.push_back("'" + s.settings.name + "' has the control's parameters: counted as a null setting (declare "
                        "it in the protocol's \"null_settings\" to say it is meant)");
      }
  }
  return {control_name, null_settings, notes};
}

}  // namespace hapticlab::planning

#include "core/sim/stability_map.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <exception>
#include <limits>
#include <mutex>
#include <stdexcept>
#include <thread>

#include <nlohmann/json.hpp>

#include "core/common/csv_format.h"
#include "core/settings/settings_json.h"

namespace hapticlab {
namespace {

// "translation.inertia.mass_kg" -> {"translation", "inertia", "mass_kg"}.
// The parameter's value set in the base, its block switched on (varying a
// disabled effect's parameter would vary nothing).
EngineSettings with_value(const nlohmann::json& base, const std::string& field, double value) {
  nlohmann::json j = base;
  const std::vector<std::string> p = split_settings_field(field);
  j[p[0]][p[1]]["enabled"] = true;
  j[p[0]][p[1]][p[2]] = value;
  return settings_from_json(j, "stability map, " + field + " = " + format_number(value)).engine;
}

double value_in(const nlohmann::json& base, const std::string& field) {
  return find_settings_field(base, field)->get<double>();
}

// Whether the block of `field` is switched on in `base` (a block without
// an "enabled" switch always is).
bool effect_on_in(const nlohmann::json& base, const std::string& field) {
  const std::vector<std::string> p = split_settings_field(field);
  const nlohmann::json& block = base.at(p[0]).at(p[1]);
  return !block.contains("enabled") || block["enabled"].get<bool>();
}

// Each value once: a repeated one would map its cells twice.
void refuse_repeats(const std::vector<double>& values, const std::string& what, const std::string& unit) {
  for (std::size_t i = 0; i < values.size(); ++i)
    if (std::find(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(i), values[i]) !=
        values.begin() + static_cast<std::ptrdiff_t>(i))
      throw std::invalid_argument("stability map: " + what + " " + format_number(values[i]) + " " + unit +
                                  " is given twice; each must be given once");
}

void validate(const StabilityMapConfig& c, const nlohmann::json& base) {
  auto bad = [](const std::string& what) { throw std::invalid_argument("stability map: " + what); };
  if (c.rates_Hz.empty()) bad("no rate given");
  for (double r : c.rates_Hz)
    if (!(r >= 150.0 && r <= 2000.0)) bad("rate " + format_number(r) + " Hz, but each must be >= 150 and <= 2000");
  refuse_repeats(c.rates_Hz, "rate", "Hz");
  if (c.stiffnesses_N_per_m.empty()) bad("no stiffness given");
  for (double k : c.stiffnesses_N_per_m)
    if (!(k >= 1e-3 && k <= 1e6))
      bad("stiffness " + format_number(k) + " N/m, but each must be >= 0.001 and <= 1000000");
  refuse_repeats(c.stiffnesses_N_per_m, "stiffness", "N/m");
  if (!(c.duration_s >= 1.5 && c.duration_s <= 600.0))
    bad("duration_s is " + format_number(c.duration_s) + ", but must be >= 1.5 and <= 600");
  if (!(c.criterion.max_oscillation_m > 0.0) || !(c.criterion.max_energy_J > 0.0))
    bad("the criterion's oscillation and energy must be > 0");
  if (c.jobs < 1) bad("jobs must be >= 1");
  if (c.parameters.empty()) bad("no parameter given");
  const std::vector<SettingsFieldInfo> reference = settings_field_reference();
  for (const StabilityParameter& p : c.parameters) {
    const auto it = std::find_if(reference.begin(), reference.end(),
                                 [&](const SettingsFieldInfo& f) { return f.path == p.field; });
    if (it == reference.end() || split_settings_field(p.field).size() != 3 || !base.contains(split_settings_field(p.field)[0]))
      bad("parameter '" + p.field + "' is not a settings field of an effect (see `hapticlab settings reference`)");
    const bool lo_ok = it->lo_exclusive ? p.range.lo > it->lo : p.range.lo >= it->lo;
    if (!lo_ok || p.range.hi > it->hi || !(p.range.lo < p.range.hi))
      bad(p.field + "'s range is " + format_number(p.range.lo) + ".." + format_number(p.range.hi) +
          ", but must lie within its allowed " + (it->lo_exclusive ? "> " : ">= ") + format_number(it->lo) +
          ", <= " + format_number(it->hi) + " with lo < hi");
    // Found here, not by a worker part way through the map.
    if (const std::string why = stability_parameter_problem(c.base, p); !why.empty())
      bad(p.field + " cannot be varied from these base settings: " + why);
  }
}

}  // namespace

std::vector<StabilityParameter> default_stability_parameters() {
  // Each over the whole range the settings allow, except where that range
  // starts at an open 0 (a decade-spanning search then starts at 1/10000
  // of Table 4.1's value or the settings' limit, whichever is larger), and
  // the levels, bisected on a linear scale from 0.
  auto log = [](std::string field, double lo, double hi) {
    return StabilityParameter{std::move(field), {lo, hi, 12, 10, true}};
  };
  auto lin = [](std::string field, double lo, double hi) {
    return StabilityParameter{std::move(field), {lo, hi, 12, 10, false}};
  };
  return {
      log("translation.inertia.mass_kg", 0.001, 10.0),
      log("translation.inertia.stiffness_N_per_m", 0.06, 100000.0),
      lin("translation.inertia.damping_ratio", 0.0, 2.0),
      log("translation.backlash.gap_m", 1e-7, 0.05),
      lin("translation.cogging.amplitude_N", 0.0, 50.0),
      lin("translation.friction.dynamic_level_N", 0.0, 50.0),
      log("translation.friction.presliding_displacement_m", 1e-8, 0.01),
      log("translation.friction.stick_velocity_m_per_s", 5e-7, 1.0),
      log("rotation.inertia.inertia_kg_m2", 1e-6, 0.1),
      log("rotation.inertia.stiffness_Nm_per_rad", 4e-4, 1000.0),
      lin("rotation.inertia.damping_ratio", 0.0, 2.0),
      log("rotation.backlash.gap_rad", 3.5e-6, 0.5),
      lin("rotation.cogging.amplitude_Nm", 0.0, 5.0),
      lin("rotation.friction.dynamic_level_Nm", 0.0, 5.0),
      log("rotation.friction.presliding_displacement_rad", 5e-7, 0.1),
      log("rotation.friction.stick_velocity_rad_per_s", 1e-5, 10.0),
  };
}

std::string stability_effect(const StabilityParameter& p) {
  const std::vector<std::string> parts = split_settings_field(p.field);
  return parts.size() > 1 ? parts[1] : p.field;
}

double StabilityCell::stable_low() const {
  if (!base_stable) return std::numeric_limits<double>::quiet_NaN();
  return below.stable;
}

double StabilityCell::stable_high() const {
  if (!base_stable) return std::numeric_limits<double>::quiet_NaN();
  return above.stable;
}

bool is_stable(const StiffContactResult& r, const StabilityCriterion& c) {
  return !r.faulted && r.oscillation_m <= c.max_oscillation_m && r.device_net_J <= c.max_energy_J;
}

EngineSettings with_passivity_enabled(EngineSettings s, bool enabled) {
  s.translation.passivity.enabled = enabled;
  s.rotation.passivity.enabled = enabled;
  return s;
}

std::string stability_parameter_problem(const EngineSettings& base, const StabilityParameter& p) {
  for (bool controller : {false, true}) {
    const nlohmann::json j = settings_to_json({"base", "", with_passivity_enabled(base, controller)});
    const nlohmann::json* field = find_settings_field(j, p.field);
    if (field == nullptr || !field->is_number() || split_settings_field(p.field).size() != 3)
      return "'" + p.field + "' is not a settings field of an effect";
    for (double v : {field->get<double>(), p.range.lo, p.range.hi}) {
      try {
        (void)with_value(j, p.field, v);
      } catch (const SettingsError& e) {
        // The settings' rule without with_value's "stability map, FIELD = V: ".
        const std::string what = e.what();
        const std::string label = "stability map, " + p.field + " = " + format_number(v) + ": ";
        return what.starts_with(label) ? what.substr(label.size()) : what;
      }
    }
  }
  return "";
}

StabilityMapSize stability_map_size(const StabilityMapConfig& c) {
  StabilityMapSize size;
  double rate_sum_Hz = 0.0;
  for (double r : c.rates_Hz) rate_sum_Hz += r;
  long per_rate_runs = 1;  // the base settings' own run
  // Per parameter: the base again, and the march out and the bisections
  // each side.
  for (const StabilityParameter& p : c.parameters) per_rate_runs += 1 + 2 * (p.range.march + p.range.steps);
  const long conditions = static_cast<long>(c.stiffnesses_N_per_m.size()) * 2;
  size.runs = per_rate_runs * conditions * static_cast<long>(c.rates_Hz.size());
  size.updates = static_cast<double>(per_rate_runs * conditions) * rate_sum_Hz * c.duration_s;
  return size;
}

namespace {

// One run of the stiff contact with settings `s`.
StiffContactResult stiff_contact_run(const StabilityMapConfig& c, const EngineSettings& s, double rate_Hz, double k) {
  StiffContactConfig run;
  run.settings = s;
  run.rate_Hz = rate_Hz;
  run.kind = c.contact;
  run.stiffness_N_per_m = k;
  run.duration_s = c.duration_s;
  return run_stiff_contact(run);
}

// One cell: whether its base value is stable, then the nearest boundary
// below and above it. `base`: the settings (controller on or off) as JSON.
// Returns the number of runs it took.
long search_cell(const StabilityMapConfig& c, const nlohmann::json& base, StabilityCell& cell) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  const StabilityParameter& p = c.parameters[cell.parameter];
  // The base value's own run, its effect switched on as every run
  // of the search has it (the base settings' run may have it off).
  long cell_runs = 0;
  cell.base_stable =
      is_stable(stiff_contact_run(c, with_value(base, p.field, cell.base_value), cell.rate_Hz, cell.stiffness_N_per_m),
                c.criterion);
  ++cell_runs;
  auto passes = [&](double v) {
    const bool ok = is_stable(stiff_contact_run(c, with_value(base, p.field, v), cell.rate_Hz, cell.stiffness_N_per_m),
                              c.criterion);
    ++cell_runs;
    cell.tried.emplace_back(v, ok);
    return ok;
  };
  // A base value outside the range searched widens it: the search
  // starts from the base.
  BoundarySearch range = p.range;
  range.lo = std::min(range.lo, cell.base_value);
  range.hi = std::max(range.hi, cell.base_value);
  auto side = [&](double to) {
    if (to != cell.base_value)
      return find_nearest_boundary(range, cell.base_value, cell.base_stable, to, passes);
    Boundary none;  // the base at the range's end: nothing beyond it
    none.kind = cell.base_stable ? BoundaryKind::kStableEverywhere : BoundaryKind::kUnstableEverywhere;
    none.stable = cell.base_stable ? to : kNaN;
    none.unstable = cell.base_stable ? kNaN : to;
    return none;
  };
  cell.below = side(range.lo);
  cell.above = side(range.hi);
  return cell_runs;
}

}  // namespace

StabilityMap run_stability_map(const StabilityMapConfig& c,
                               const std::function<void(std::size_t, std::size_t)>& progress) {
  const nlohmann::json base_json = settings_to_json({"base", "", c.base});
  validate(c, base_json);
  StabilityMap map;
  for (double rate : c.rates_Hz)
    for (double k : c.stiffnesses_N_per_m)
      for (bool controller : {false, true}) map.base_runs.push_back({rate, k, controller, {}, false});
  for (std::size_t p = 0; p < c.parameters.size(); ++p)
    for (const StabilityBaseRun& b : map.base_runs) {
      StabilityCell cell;
      cell.parameter = p;
      cell.rate_Hz = b.rate_Hz;
      cell.stiffness_N_per_m = b.stiffness_N_per_m;
      cell.controller = b.controller;
      cell.base_value = value_in(base_json, c.parameters[p].field);
      cell.base_effect_on = effect_on_in(base_json, c.parameters[p].field);
      map.cells.push_back(std::move(cell));
    }
  // The settings with and without the controller, as JSON, made once.
  const nlohmann::json off_json = settings_to_json({"base", "", with_passivity_enabled(c.base, false)});
  const nlohmann::json on_json = settings_to_json({"base", "", with_passivity_enabled(c.base, true)});

  const std::size_t tasks = map.base_runs.size() + map.cells.size();
  std::atomic<std::size_t> next{0};
  std::atomic<long> runs{0};
  std::mutex report;
  std::size_t done = 0;
  std::exception_ptr failure;
  auto worker = [&] {
    for (std::size_t t; (t = next.fetch_add(1)) < tasks;) {
      try {
        if (t < map.base_runs.size()) {
          StabilityBaseRun& b = map.base_runs[t];
          b.result = stiff_contact_run(c, with_passivity_enabled(c.base, b.controller), b.rate_Hz, b.stiffness_N_per_m);
          b.stable = is_stable(b.result, c.criterion);
          runs.fetch_add(1);
        } else {
          StabilityCell& cell = map.cells[t - map.base_runs.size()];
          const long cell_runs = search_cell(c, cell.controller ? on_json : off_json, cell);
          runs.fetch_add(cell_runs);
        }
      } catch (...) {
        const std::lock_guard<std::mutex> lock(report);
        if (!failure) failure = std::current_exception();
        next.store(tasks);
        return;
      }
      const std::lock_guard<std::mutex> lock(report);
      ++done;
      if (progress) progress(done, tasks);
    }
  };
  std::vector<std::thread> threads;
  const std::size_t n = std::min(c.jobs, tasks);
  for (std::size_t i = 1; i < n; ++i) threads.emplace_back(worker);
  worker();
  for (std::thread& th : threads) th.join();
  if (failure) std::rethrow_exception(failure);
  map.runs = runs.load();
  return map;
}

}  // namespace hapticlab

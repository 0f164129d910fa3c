#pragma once
// The stability map (issue 19 §2): for every update rate, the largest (or
// smallest) value of each effect parameter at which a stiff contact stays
// stable, with and without the passivity controller — the thesis' Table 4.1
// for any rate, found by bisection instead of by hand.
//
// Each parameter is varied alone, every other field keeping its value in
// the base settings (by default Table 4.1's set, everything on at once, as
// the thesis' table was found). The contact is run_stiff_contact's; a run is
// stable when it did not fault, the tip's peak-to-peak motion over the last
// second is at most `max_oscillation_m` and the net energy the device gave
// the hand over the run is at most `max_energy_J`.
//
// Deterministic: every run is, and the cells are independent, so the map is
// the same whatever the number of threads.
#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "core/settings/settings.h"
#include "core/sim/boundary_search.h"
#include "core/sim/stiff_contact.h"

namespace hapticlab {

struct StabilityParameter {
  std::string field;  // a settings path, e.g. "translation.inertia.mass_kg"
  BoundarySearch range;
};

// The parameters of Table 4.1 (inertia mass, coupling stiffness and damping
// ratio; backlash gap; cogging amplitude; friction presliding displacement
// and stick velocity) and friction's level, for translation and rotation,
// each over its allowed settings range (docs/engine.md, "Stability map").
std::vector<StabilityParameter> default_stability_parameters();

// The effect a parameter belongs to: "inertia" for
// "translation.inertia.mass_kg".
std::string stability_effect(const StabilityParameter& p);

struct StabilityCriterion {
  double max_oscillation_m = 0.5e-3;  // issue 19's half millimetre
  double max_energy_J = 0.02;         // docs/engine.md, "Stability map"
};

bool is_stable(const StiffContactResult& r, const StabilityCriterion& c);

struct StabilityMapConfig {
  EngineSettings base;
  std::vector<double> rates_Hz{150, 300, 500, 1000, 2000};  // each 150..2000
  std::vector<double> stiffnesses_N_per_m{320, 2000};        // the VE's, each > 0
  StiffContactKind contact = StiffContactKind::kGraspedTissue;
  std::vector<StabilityParameter> parameters = default_stability_parameters();
  StabilityCriterion criterion;
  double duration_s = 3.0;  // of every run, >= 1.5
  std::size_t jobs = 1;     // threads, >= 1
};

// The base settings themselves at one rate, stiffness and controller state.
struct StabilityBaseRun {
  double rate_Hz = 0.0;
  double stiffness_N_per_m = 0.0;
  bool controller = false;
  StiffContactResult result;
  bool stable = false;
};

// One parameter at one rate, stiffness and controller state. The search
// starts from the base value (run with its effect switched on, as every
// run of the search is; for Table 4.1's set that is the base run) and goes out towards each end of the parameter's range for the
// nearest change (boundary_search.h): `below` towards range.lo, `above`
// towards range.hi. So when the base is stable the map gives the stable
// interval around it (Table 4.1's "largest stable mass" is above.stable),
// and when it is not, the nearest stable value on each side, if any.
struct StabilityCell {
  std::size_t parameter = 0;  // index into config.parameters
  double rate_Hz = 0.0;
  double stiffness_N_per_m = 0.0;
  bool controller = false;
  double base_value = 0.0;  // the parameter's value in the base settings
  // Whether the parameter's effect is on in the base settings. When it is
  // off, base_value is what its disabled block holds (the field's default
  // unless the file set it): the search starts there, the effect switched
  // on, so a report must not show it as the base settings' own value.
  bool base_effect_on = true;
  bool base_stable = false;
  // kind kStableEverywhere: stable out to the range's end; kStableAbove /
  // kStableBelow: a boundary; kUnstableEverywhere: no stable value found.
  // A side without room (the base at the range's end) is kStableEverywhere
  // or kUnstableEverywhere with 0 runs, as the base is.
  Boundary below;
  Boundary above;
  // The values tried, in order, and whether each passed.
  std::vector<std::pair<double, bool>> tried;

  // The stable interval around a stable base: [low, high] (an end of the
  // range when no boundary lies that way). NaN when the base is unstable.
  double stable_low() const;
  double stable_high() const;
};

struct StabilityMap {
  std::vector<StabilityBaseRun> base_runs;  // rate-major, then stiffness, off before on
  std::vector<StabilityCell> cells;         // parameter-major, then as base_runs
  long runs = 0;
};

// Runs of run_stiff_contact the map needs at most, and the device updates
// they take (to estimate the time before starting).
struct StabilityMapSize {
  long runs = 0;
  double updates = 0.0;
};
StabilityMapSize stability_map_size(const StabilityMapConfig& config);

// Why the map cannot vary `p` from `base`, or empty when it can. Every run
// of a parameter's search has its effect switched on, which a rule of the
// settings may forbid in this base: backlash needs inertia on. The text is
// the settings' own message ("settings block 'translation.backlash' needs
// 'translation.inertia' enabled: ..."), checked at the base value and at
// both ends of the range, with the passivity controller off and on.
std::string stability_parameter_problem(const EngineSettings& base, const StabilityParameter& p);

// Throws std::invalid_argument naming the field for a bad rate, stiffness,
// duration or parameter (a settings path that does not exist, a range
// outside the field's allowed one, an effect the base settings cannot have
// switched on: stability_parameter_problem), or a rate or stiffness given
// twice, before any run. `progress` (may be empty) is called
// after every cell, from one thread at a time, with cells done and total.
StabilityMap run_stability_map(const StabilityMapConfig& config,
                               const std::function<void(std::size_t, std::size_t)>& progress = {});

// The settings with the passivity controller on (or off) on every axis,
// its other fields kept.
EngineSettings with_passivity_enabled(EngineSettings s, bool enabled);

}  // namespace hapticlab

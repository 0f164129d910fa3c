#pragma once
// Parameters of the per-DOF degradation models.
//
// One struct serves the translational axis (insertion) and the rotational
// axes (pitch, yaw): the models are the same equations, only the units
// differ. In the comments, [F] is N on the insertion axis and N·m on pitch and
// yaw; [X] is m on insertion and rad on pitch and yaw; [M] is kg on insertion
// and kg·m² on pitch and yaw. The JSON settings files carry these units in
// every field name (see settings_json.h).

namespace hapticlab {

enum class AxisKind { kTranslation, kRotation };

// Nahvi–Hollerbach stick–slip friction with a pre-sliding spring
// (thesis eq. 2.10–2.12); normal force taken as one unit.
struct FrictionParams {
  bool enabled = false;
  double dynamic_level = 0.0;           // [F] slip friction, also the breakaway level
  double presliding_displacement = 0.0; // [X] spring stretch at breakaway, > 0
  double stick_velocity = 0.0;          // [X/s] below this the contact sticks, > 0
};

// Position-periodic cogging force plus optional torque ripple (thesis 2.2.4,
// 4.2.1.1).
struct CoggingParams {
  bool enabled = false;
  double amplitude = 0.0;      // [F] peak cogging force
  double period = 0.0;         // [X] spatial period of the detents, > 0
  double phase_rad = 0.0;      // phase of the sinusoid at position 0
  double ripple_fraction = 0.0;  // [-] 0..0.5: commanded force is scaled by 1 + r·sin(...)
  double ripple_period = 0.0;    // [X] spatial period of the ripple, > 0
};

// Clip of the VE force on this axis (the F_ves of thesis Fig. 2-11).
struct SaturationParams {
  bool enabled = false;
  double level = 0.0;  // [F] >= 0; 0 removes the VE force on this axis
};

// Virtual mass coupled to the instrument by a spring–damper (thesis eq.
// 2.1–2.2, Fig. 2-2). Backlash reuses this mass and coupling.
struct InertiaParams {
  bool enabled = false;
  double mass = 0.0;           // [M] >= 1e-3 kg (translation), >= 1e-6 kg·m² (rotation)
  double stiffness = 0.0;      // [F/X] coupling spring K, > 0
  double damping_ratio = 0.0;  // [-] B as a fraction of critical damping 2·sqrt(K·m)
};

// Gap between the instrument and the virtual mass, with Karnopp friction on
// the free mass (thesis eq. 2.7, 2.8, 2.13, 2.14). Needs inertia enabled.
struct BacklashParams {
  bool enabled = false;
  double gap = 0.0;                 // [X] full gap width, > 0
  double static_friction = 0.0;     // [F] Karnopp stick limit on the free mass
  double dynamic_friction = 0.0;    // [F] Karnopp slip level, <= static_friction
  double stick_velocity = 0.0;      // [X/s] Karnopp stick band
};

// Encoder quantization of the measured position (beyond the thesis, Fig. 2-1).
struct EncoderParams {
  bool enabled = false;
  double counts_per_unit = 0.0;  // [1/X] counts per m or per rad, > 0
};

// Time-domain passivity observer and controller on an axis' commanded
// force (Hannaford & Ryu 2002; core/models/passivity.h): damping added only
// while the axis has given out more energy than it took in over the last
// `window_s`. Off unless a settings file turns it on; the thesis' settings
// leave it off, so they run as the thesis ran them.
struct PassivityParams {
  bool enabled = false;
  double window_s = 0.0;      // [s] observer window, > 0 and <= kMaxPassivityWindow_s
  double min_velocity = 0.0;  // [X/s] below this no damping is computed (v² would blow it up), > 0
  double max_damping = 0.0;   // [F·s/X] cap on the damping the controller adds, > 0
};
// The window's ring buffer holds this much at the fastest update rate (2 kHz).
inline constexpr double kMaxPassivityWindow_s = 2.0;

struct AxisSettings {
  FrictionParams friction;
  CoggingParams cogging;
  SaturationParams saturation;
  InertiaParams inertia;
  BacklashParams backlash;
  EncoderParams encoder;
  PassivityParams passivity;
};

}  // namespace hapticlab

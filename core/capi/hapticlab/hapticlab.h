/*
 * HapticLab degradation engine: plain C API.
 *
 * Put this library between a haptic device driver and a virtual environment
 * (VE). On every haptic update the driver passes the measured joint positions
 * of one instrument, the time since that instrument's previous update, and the
 * force the VE wants on the tool tip. The engine returns the force to command
 * on the device, and the positions to show the VE, so that the device feels
 * like inexpensive hardware (friction, cogging, backlash, inertia, force
 * saturation, coarse encoders, a slow loop).
 *
 * Units are SI everywhere: m, rad, N, N·m, s.
 * Joints of an instrument: insertion (m, pivot to tip), pitch (rad), yaw (rad).
 * World frame: origin at the instrument's pivot (trocar), z up, out of the
 * patient; at pitch = yaw = 0 the instrument points along -z. A positive
 * insertion force pushes toward larger insertion. See docs/engine.md.
 *
 * Threads: hl_engine_update() and hl_engine_refresh_forces() must be called
 * from one thread (the haptic loop); they never allocate, lock, block or do
 * I/O. hl_engine_set_settings() and hl_engine_halt()
 * may be called from any other thread; the change takes effect between two
 * updates. Create and destroy from a non-real-time thread.
 */
#ifndef HAPTICLAB_HAPTICLAB_H_
#define HAPTICLAB_HAPTICLAB_H_

#include <stddef.h>
#include <stdint.h>

#if defined(HAPTICLAB_BUILDING_LIBRARY)
#define HL_API __attribute__((visibility("default")))
#else
#define HL_API
#endif

#ifdef __cplusplus
extern "C" {
#endif

typedef struct hl_engine hl_engine;

/* Return codes. */
#define HL_OK 0
#define HL_ERROR_INVALID_ARGUMENT (-1) /* null pointer, bad instrument index */
#define HL_ERROR_SETTINGS (-2)         /* settings JSON missing, malformed or out of range */

/* Status bits of hl_output.status (same values as hapticlab::StatusFlag). */
#define HL_FAULT_NON_FINITE_INPUT 0x01u /* NaN/inf input: force is zero this update */
#define HL_FAULT_NON_FINITE_STATE 0x02u /* internal fault: force zero, state reset */
#define HL_DT_DEFERRED 0x04u            /* dt < 1/2000 s: no time advanced yet, carried over */
#define HL_DT_SUBSTEPPED 0x08u          /* dt > 1/150 s: split into sub-steps */
#define HL_DT_RESYNCED 0x10u            /* stall > ~53 ms: states re-anchored */
#define HL_FORCE_LIMITED 0x20u          /* a joint force hit the device limit */
#define HL_FAULT_INVALID_ARGUMENT 0x40u /* bad call: force is zero */
/* The caller's clock stopped: HL_CLOCK_STOPPED_UPDATES updates in a row
 * advanced no time (dt <= 0, or below 1/2000 s all together; a caller at up
 * to 32 kHz never gets there). Force is zero until an update advances time, which re-anchors the
 * states (HL_DT_RESYNCED): a hand moving while no time passes would stretch
 * an emulated inertia's coupling to the device limit. */
#define HL_FAULT_CLOCK_STOPPED 0x80u
#define HL_CLOCK_STOPPED_UPDATES 20
#define HL_FAULT_MASK 0xC3u             /* bits meaning "the force was zeroed" */
/* The engine was halted (hl_engine_halt): force is zero, for good. Not an
 * engine fault, so not in HL_FAULT_MASK; test it on its own. */
#define HL_HALTED 0x8000u
/* The force was scaled down by the ramp-in (hl_engine_set_ramp_in). */
#define HL_RAMPING 0x4000u

typedef struct hl_input {
  double dt_s;           /* time since this instrument's previous update, s */
  double insertion_m;    /* measured insertion, m */
  double pitch_rad;      /* measured pitch, rad */
  double yaw_rad;        /* measured yaw, rad */
  double ve_force_N[3];  /* force the VE applies to the tool tip, world frame, N */
} hl_input;

typedef struct hl_output {
  double displayed_force_N[3]; /* force to command at the tool tip, world frame, N */
  double insertion_force_N;    /* the same as joint commands: insertion force, N */
  double pitch_torque_Nm;      /* pitch torque, N·m */
  double yaw_torque_Nm;        /* yaw torque, N·m */
  double degraded_insertion_m; /* positions to give the VE */
  double degraded_pitch_rad;
  double degraded_yaw_rad;
  double tip_offset_m[3];      /* VE tip position minus measured tip, world frame (eq. 2.20) */
  double orientation_offset[9]; /* row-major world rotation, measured -> VE tool (eq. 2.21) */
  uint32_t status;             /* HL_* status bits */
} hl_output;

/* Library version, e.g. "0.1.0". */
HL_API const char* hl_version(void);

/*
 * Creates an engine with two instruments (0 = left, 1 = right) from a
 * settings JSON text (the format of examples/settings/). Both instruments
 * start at rest at 0.1 m insertion, pitch = yaw = 0; the first update with
 * real positions re-anchors them (it reports HL_DT_RESYNCED).
 * On failure returns NULL and, if error is not NULL, writes a message naming
 * the bad field, its value and the allowed range (truncated to error_size).
 */
HL_API hl_engine* hl_engine_create(const char* settings_json, char* error, size_t error_size);

/* Same, reading the settings from a file. */
HL_API hl_engine* hl_engine_create_from_file(const char* path, char* error, size_t error_size);

/*
 * One haptic update of one instrument. Returns HL_OK, or
 * HL_ERROR_INVALID_ARGUMENT (then *out, if given, holds zero force and
 * HL_FAULT_INVALID_ARGUMENT). Non-finite inputs are not an error: the output
 * force is zero and status has HL_FAULT_NON_FINITE_INPUT.
 */
HL_API int hl_engine_update(hl_engine* engine, int instrument, const hl_input* in,
                            hl_output* out);

/*
 * Optional second half of an update, for drivers that run read device ->
 * engine -> VE -> engine -> write device: after hl_engine_update() gave the
 * degraded positions and the VE computed its force for them, this puts that
 * force through the degradations, so the device displays it in the same
 * update instead of the next. Without it, in->ve_force_N of the next
 * hl_engine_update() is the only way the VE force reaches the device (one
 * update later), which is also correct, just 1/rate later.
 *
 * `out` must be what hl_engine_update() returned for this instrument in this
 * update: its forces, joint commands and status are replaced; positions and
 * offsets stay. It works once per successful hl_engine_update(): a second
 * call, or one after an hl_engine_update() that returned an error, leaves
 * *out untouched and does not look at ve_force_N. After an update whose
 * status has a fault bit, the update's zero force is written back.
 *
 * Exact where a degradation only adds to the VE force. Axes with backlash and
 * inertia together keep the force hl_engine_update() was given (the mass was
 * already moved by it), and with force latency or hold emulation the update's
 * forces are written back unchanged (the emulation sets the VE force's
 * timing itself). Otherwise a non-finite ve_force_N zeroes the force and sets
 * HL_FAULT_NON_FINITE_INPUT.
 * Returns HL_OK, or HL_ERROR_INVALID_ARGUMENT for a null pointer or a bad
 * instrument index (then *out is untouched). Call it on the thread that calls
 * hl_engine_update(); it is real-time safe like hl_engine_update().
 */
HL_API int hl_engine_refresh_forces(hl_engine* engine, int instrument,
                                    const double ve_force_N[3], hl_output* out);

/*
 * Replaces the settings of a running engine. The text is validated first; on
 * any error nothing changes and HL_ERROR_SETTINGS is returned with a message.
 */
HL_API int hl_engine_set_settings(hl_engine* engine, const char* settings_json, char* error,
                                  size_t error_size);

/*
 * Operator stop: from the next hl_engine_update() on (the one running now
 * may still return its force), every update and refresh of every instrument
 * outputs zero force and zero joint commands, with HL_HALTED in status;
 * positions are still degraded and returned, so the VE can go on drawing.
 * It cannot be undone: create a new engine. Callable from any thread while
 * the loop runs (an atomic flag; no lock). NULL is ignored.
 */
HL_API void hl_engine_halt(hl_engine* engine);

/*
 * Force ramp-in, so that a trial never begins with a step to a large force
 * (a VE that starts in contact, a degradation with a standing force): each
 * instrument's forces and joint commands are scaled by min(1, t / ramp_s),
 * t being the sum of that instrument's dt of the updates before this one
 * since this call (so the first update commands exactly 0), with HL_RAMPING
 * in status while the scale is below 1. ramp_s = 0 turns it off (the
 * default of hl_engine_create). The engines of the study API's trials ramp
 * in over 0.3 s, as HapticLab's own loop does (docs/safety.md). Call it
 * before the loop runs, or between trials; returns HL_ERROR_INVALID_ARGUMENT
 * for a NULL engine or a ramp_s that is negative, NaN or above 10 s.
 */
HL_API int hl_engine_set_ramp_in(hl_engine* engine, double ramp_s);

/*
 * Fixes the engine's settings and ramp-in as they are now, for good:
 * afterwards hl_engine_set_settings returns HL_ERROR_SETTINGS (nothing
 * changes) and hl_engine_set_ramp_in returns HL_ERROR_INVALID_ARGUMENT for
 * a ramp shorter than the fixed one (a longer one is allowed). The study
 * API fixes the engine of each trial: the trial's setting is what the
 * study stores as felt, and its ramp-in is a safety measure. NULL is
 * ignored.
 */
HL_API void hl_engine_fix_settings(hl_engine* engine);

HL_API void hl_engine_destroy(hl_engine* engine);

/*
 * Joint-to-tip kinematics of one instrument pivoting about its trocar
 * (thesis eq. 2.20): the tool tip at (insertion_m, pitch_rad, yaw_rad) in
 * the world frame of that instrument's trocar, the frame of
 * hl_input.ve_force_N and hl_output (origin at the pivot, z up out of the
 * patient; at pitch = yaw = 0 the tool points down -z):
 *
 *   tip = insertion · ( sin(yaw)·cos(pitch), sin(pitch), −cos(yaw)·cos(pitch) )  [m]
 *
 * Give it the degraded joints (hl_output degraded_*) for the tip the VE
 * shows, which is what hl_sample's tip_position_m asks for. The analysis
 * needs only a fixed origin per instrument (paths and speeds are
 * differences); HapticLab's own sessions add the trocar's place on the
 * workstation (x = -0.05 m left, +0.05 m right). Real-time safe. Returns
 * HL_ERROR_INVALID_ARGUMENT for a NULL tip_m (then nothing is written);
 * non-finite joints give a non-finite tip.
 */
HL_API int hl_tip_position(double insertion_m, double pitch_rad, double yaw_rad, double tip_m[3]);

#ifdef __cplusplus
}
#endif

#endif /* HAPTICLAB_HAPTICLAB_H_ */

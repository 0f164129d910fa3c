/*
 * HapticLab device plugin ABI, version 1.
 *
 * A device plugin is a shared library through which HapticLab drives a
 * haptic device: `hapticlab session run --device plugin:PATH.so` and
 * `hapticlab device check --device plugin:PATH.so`. HapticLab runs the
 * haptic loop; the plugin moves joint positions in and forces out. It
 * exports one C function,
 *
 *     const hl_device_plugin* hl_device_plugin_entry(void);
 *
 * returning a table of functions that lives as long as the library is
 * loaded (a static const object). HapticLab checks abi_version and
 * struct_size before it touches anything else and refuses a plugin built
 * against another version of this header. Build a plugin against the header
 * of the HapticLab it will run in; examples/device_plugin/ is a skeleton.
 *
 * Units are SI. Joint order per instrument (index 0..4), as in HapticLab's
 * Laparoscopic Surgical Workstation:
 *   insertion [m], pitch [rad], yaw [rad], handle twist [rad], grip [rad].
 * Forces follow the same order: insertion [N], the others [N·m]. Instrument
 * 0 is the left, 1 the right. A device with fewer joints reports its
 * unused joints as fixed (a constant reading) and ignores their forces.
 *
 * Lifecycle (each call returns an hl_device_status, HL_DEVICE_OK = success):
 *   create(options)         parse and check the options; no power yet
 *   configure(rate, seed)   open communication; may be called again while
 *                           inactive
 *   ratings(out)            after a successful configure: limits of every joint
 *   activate(clock)         enable the amplifiers; HL_DEVICE_NOT_CALIBRATED
 *                           if the device is not calibrated or homed (it
 *                           is then not driven; the operator is told)
 *   { read, write }*        one read and one write per loop update
 *   deactivate()            zero force, amplifiers off; always safe to call
 *   destroy()               release everything (calls deactivate if needed)
 * halt() may come at any time from any thread (the loop's watchdog, an
 * operator stop): cut the force output now and keep it off until the next
 * activate(). Zero force means the motors exert nothing: command zero
 * current (or disable the amplifier), not "hold the last position".
 *
 * Threads and real time: create, configure, ratings, activate, deactivate,
 * destroy and name run on HapticLab's control thread, never concurrently
 * with read/write. read and write run on the haptic loop's thread, at up to
 * 2 kHz: they must not allocate, lock a mutex another thread may hold, log,
 * sleep or block beyond the device's own bus transfer. They return a
 * status; they never exit, throw or longjmp. A C++ plugin must not let an
 * exception cross this ABI.
 *
 * HapticLab's side of the contract: a command never holds NaN or infinity;
 * a reading with a non-finite position is treated as
 * HL_DEVICE_NON_FINITE_READING whatever status came with it; forces are
 * kept within the ratings' peak force (and any lower limit the study sets).
 * When HapticLab starts a session it first loads the plugin in a child
 * process and calls create, configure, ratings and destroy there, so a
 * plugin that crashes is reported before anything is stored.
 *
 * Isolated mode (`--device plugin-isolated:PATH.so`): the plugin may run
 * in a process of its own that HapticLab starts and supervises (the
 * `hapticlab` executable, loading the library as above), every call
 * crossing shared memory. A crash or hang there ends the trial with its
 * reason ("device_crashed: SIGSEGV in read", "device read hung for 15 ms")
 * instead of the session. What that means for a plugin:
 *   - It shares no memory with the session's process: no global state in
 *     common with HapticLab or with other libraries loaded there (what
 *     the plugin needs initialized, it initializes itself), and no file
 *     descriptor of the session's is open in its process. Its stdout and
 *     stderr are the session's; its stdin is /dev/null.
 *   - Calls come from the host process's threads, one at a time as above;
 *     halt() comes on a thread of its own, concurrently with a read or
 *     write that may be stuck in the bus transfer, and must cut the force
 *     from there.
 *   - The clock arrives with each call: now_s(context) returns the loop
 *     clock's time at which HapticLab made the current call (the same value
 *     throughout the call), so a simulated device stays deterministic.
 *     Outside a call it returns the last call's time.
 *   - A call that does not return within its bound (15 ms for read, write
 *     and the simulation extension on the wall clock, 1 s on the virtual
 *     clock, 2 s for deactivate, 10 s for the others) gets halt(), on a
 *     thread of its own that runs at a real-time priority above the loop's
 *     when the loop has one, and 10 ms later the process is killed whether
 *     halt() has returned or not: destroy() is not called, so a device must
 *     also stop its motors when its process ends (the driver's file
 *     descriptors close; a hardware watchdog is best).
 *   - The process dies with the session (SIGKILL when HapticLab ends), and
 *     each trial starts a new one.
 * HL_DEVICE_CRASHED and HL_DEVICE_HUNG below are HapticLab's statuses for
 * such a process, never a plugin's.
 */
#ifndef HAPTICLAB_DEVICE_PLUGIN_H_
#define HAPTICLAB_DEVICE_PLUGIN_H_

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* The ABI this header describes. A new version changes this number. */
#define HL_DEVICE_PLUGIN_ABI_VERSION 1u
#define HL_DEVICE_PLUGIN_ENTRY "hl_device_plugin_entry"

#define HL_DEVICE_NUM_INSTRUMENTS 2
#define HL_DEVICE_NUM_JOINTS 5

/* Status codes; the same values as HapticLab's DeviceStatus. */
typedef int32_t hl_device_status;
#define HL_DEVICE_OK 0
#define HL_DEVICE_NOT_CONFIGURED 1     /* activate() before configure() */
#define HL_DEVICE_NOT_ACTIVE 2         /* read()/write() outside activate()..deactivate() */
#define HL_DEVICE_INVALID_CONFIG 3     /* configure() got a value it cannot use */
#define HL_DEVICE_READ_FAILED 4        /* the transfer failed (bus error, unplugged) */
#define HL_DEVICE_NON_FINITE_READING 5 /* the device returned NaN or infinity */
#define HL_DEVICE_OUT_OF_RANGE 6       /* a reading lies outside the joint's mechanical range */
#define HL_DEVICE_WRITE_FAILED 7       /* the force command could not be sent */
#define HL_DEVICE_END_OF_DATA 8        /* a recording is exhausted (replay devices) */
#define HL_DEVICE_NOT_CALIBRATED 9     /* activate(): not calibrated or homed; must not be driven */
#define HL_DEVICE_TIMEOUT 10           /* read(): no answer within the device's timeout */
/* HapticLab's own, for a plugin run isolated (see above); a plugin never
 * returns them (one that does gets the call's failure status instead). */
#define HL_DEVICE_CRASHED 11 /* the plugin's process died during the call */
#define HL_DEVICE_HUNG 12    /* the call did not return in time; the plugin's process was killed */

/* The plugin's own device object; HapticLab only passes the pointer back. */
typedef struct hl_device hl_device;

/* The haptic loop's clock. A simulated device advances its physics to
 * now_s(context) on every read, so a session on HapticLab's virtual clock
 * stays deterministic; hardware ignores it. Valid from activate() until
 * deactivate() returns; call it only from read/write. */
typedef struct hl_device_clock {
  void* context;
  double (*now_s)(void* context); /* [s], never decreasing */
} hl_device_clock;

/* Limits of one joint. [X] = m for insertion, rad otherwise; [F] = N or
 * N·m. HapticLab refuses a plugin whose ratings are not finite or break the
 * inequalities below. */
typedef struct hl_device_joint_rating {
  double min_position;     /* [X] mechanical range, lower end */
  double max_position;     /* [X] > min_position */
  double continuous_force; /* [F] >= 0, sustainable output */
  double peak_force;       /* [F] >= continuous_force, short-term output */
  double max_velocity;     /* [X/s] > 0; faster is treated as a runaway or a bad reading */
} hl_device_joint_rating;

typedef struct hl_device_ratings {
  hl_device_joint_rating joint[HL_DEVICE_NUM_INSTRUMENTS][HL_DEVICE_NUM_JOINTS];
} hl_device_ratings;

typedef struct hl_device_reading {
  double position[HL_DEVICE_NUM_INSTRUMENTS][HL_DEVICE_NUM_JOINTS]; /* [m, rad] */
  double device_time_s; /* the device's own timestamp [s], or NaN if it has none */
} hl_device_reading;

typedef struct hl_device_command {
  double force[HL_DEVICE_NUM_INSTRUMENTS][HL_DEVICE_NUM_JOINTS]; /* [N, N·m] */
} hl_device_command;

/* --- Simulation extension (simulated devices only; hardware sets it NULL).
 * A simulated participant holds a simulated device through a spring–damper
 * to a moving reference; HapticLab's simulated participant drives it
 * through these calls, between read() and write() on the loop thread
 * (set_start_pose: control thread, before activate). */
typedef struct hl_hand_coupling {
  double reference_position; /* [X] where the hand wants the joint now */
  double reference_velocity; /* [X/s] the reference moves on linearly until the next set_hand */
  double stiffness;          /* [F/X] >= 0 */
  double damping;            /* [F·s/X] >= 0 */
  double force;              /* [F] feed-forward push */
  double mass;               /* [kg or kg·m²] >= 0, hand mass moving with the handle */
} hl_hand_coupling;

typedef struct hl_device_sim_extension {
  /* Start pose of one instrument (0 or 1), velocities zero; returns 1 if
   * taken, 0 for a bad instrument, a pose outside the range, or while active. */
  int (*set_start_pose)(hl_device* device, int instrument, const double position[HL_DEVICE_NUM_JOINTS]);
  /* The hand's coupling from the current loop time on. A coupling with a
   * non-finite field or a negative stiffness, damping or mass releases
   * that joint. */
  void (*set_hand)(hl_device* device, int instrument, const hl_hand_coupling hand[HL_DEVICE_NUM_JOINTS]);
  /* What the hand exerted on the handle in the last physics step [N, N·m]. */
  void (*hand_force)(const hl_device* device, int instrument, double force[HL_DEVICE_NUM_JOINTS]);
  /* Motor output in the last physics step, after the device's limits. */
  void (*motor_force)(const hl_device* device, int instrument, double force[HL_DEVICE_NUM_JOINTS]);
} hl_device_sim_extension;

/* The function table. Every function pointer except `sim` is required. */
typedef struct hl_device_plugin {
  uint32_t abi_version; /* HL_DEVICE_PLUGIN_ABI_VERSION */
  uint32_t struct_size; /* sizeof(hl_device_plugin) */

  /* options: `count` key/value pairs from `--device-option key=value`
   * (UTF-8, NUL-terminated, valid only during the call). Reject a key you
   * do not know or a bad value: return NULL and write a message naming
   * the key, the value and what is allowed into error[0..error_size)
   * (NUL-terminated). */
  hl_device* (*create)(const char* const* keys, const char* const* values, size_t count, char* error,
                       size_t error_size);
  /* nominal_rate_Hz: the loop rate, 150..2000. seed: for anything random
   * in a simulated device; hardware ignores it. */
  hl_device_status (*configure)(hl_device* device, double nominal_rate_Hz, uint64_t seed);
  /* After a successful configure; fixed until the next configure. */
  hl_device_status (*ratings)(const hl_device* device, hl_device_ratings* out);
  hl_device_status (*activate)(hl_device* device, const hl_device_clock* clock);
  /* Loop thread. Fill every position, or return a fault status. */
  hl_device_status (*read)(hl_device* device, hl_device_reading* reading);
  /* Loop thread. Clip to the peak force; ignore unactuated joints. */
  hl_device_status (*write)(hl_device* device, const hl_device_command* command);
  /* Zero force, amplifiers off. */
  hl_device_status (*deactivate)(hl_device* device);
  /* Any thread, concurrently with read/write: force output off now
   * (an atomic flag write() checks, an amplifier enable line). */
  void (*halt)(hl_device* device);
  /* A short name for logs ("acme-lsw"); static storage. */
  const char* (*name)(const hl_device* device);
  void (*destroy)(hl_device* device);

  const hl_device_sim_extension* sim; /* NULL for hardware */
} hl_device_plugin;

#if defined(__GNUC__)
#define HL_DEVICE_PLUGIN_EXPORT __attribute__((visibility("default")))
#else
#define HL_DEVICE_PLUGIN_EXPORT
#endif

/* What a plugin defines (HapticLab looks it up with dlsym). */
HL_DEVICE_PLUGIN_EXPORT const hl_device_plugin* hl_device_plugin_entry(void);

#ifdef __cplusplus
}
#endif

#endif /* HAPTICLAB_DEVICE_PLUGIN_H_ */

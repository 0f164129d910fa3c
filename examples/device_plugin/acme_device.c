/*
 * A skeleton of a lab's own device plugin (hapticlab/device_plugin.h).
 * Copy it, rename "acme", and fill in the places marked BUS: that is where
 * your device's own transfer goes (USB, EtherCAT, a PCI card, a vendor SDK).
 * As shipped it talks to no hardware: it reports a device resting at a fixed
 * pose, so it builds and passes `hapticlab device check` anywhere.
 *
 *   cmake -S examples/device_plugin -B build-plugin -DCMAKE_PREFIX_PATH=/path/to/install
 *   cmake --build build-plugin
 *   hapticlab device check --device plugin:build-plugin/acme_device.so --device-option port=/dev/ttyUSB0
 *
 * Run `device check` first: it reads for 2 s at the loop rate while
 * commanding zero force and prints the rate, jitter, joint ranges and faults.
 * While the plugin is new, check it isolated (`--device
 * plugin-isolated:build-plugin/acme_device.so`): it then runs in a process of
 * its own, and a crash or a hang in it is reported ("device_crashed: SIGSEGV
 * in read") instead of ending `hapticlab`.
 * When the ranges match what you move by hand, run a session with
 * `hapticlab session run --device plugin:.../acme_device.so ...`.
 *
 * Rules that matter for the participant's safety (the header says more):
 *  - read() and write() run on the haptic loop's thread at up to 2 kHz: no
 *    malloc, no printf, no mutex another thread holds, no sleeping. Only
 *    the bus transfer may block, and only for its own short time.
 *  - Zero force on deactivate() and halt(): the motors exert nothing (zero
 *    current, or the amplifier disabled), not "hold position". halt() comes
 *    from another thread while read()/write() may be running: it sets a flag
 *    that write() honours and, if the hardware has one, drops the amplifier
 *    enable line right there.
 *  - Report HL_DEVICE_NOT_CALIBRATED from activate() if the encoders are not
 *    homed: HapticLab then refuses to start and tells the operator.
 *  - Clip every force to the peak force you report in ratings().
 *  - Isolated, the process may be killed (a call that hangs): make the
 *    device stop its motors when its connection closes, if it can.
 */
#include <hapticlab/device_plugin.h>

#include <math.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct hl_device {
  char port[256];        /* option port=..., where the device is attached */
  double rate_Hz;        /* from configure() */
  int configured, active;
  atomic_int halted;     /* set by halt() from any thread, cleared by activate() */
  hl_device_ratings ratings;
};

/* Your device's ranges and motor limits, per instrument and joint. These are
 * the Laparoscopic Surgical Workstation's (thesis Table 2.1); measure yours.
 * max_velocity is a runaway guard: faster than any hand moves the handle. */
static const hl_device_joint_rating kJoint[HL_DEVICE_NUM_JOINTS] = {
    /* min [m|rad], max, continuous [N|N*m], peak, max velocity [/s] */
    {0.0, 0.170, 11.0, 19.0, 2.0},         /* insertion */
    {-0.8727, 0.8727, 0.47, 0.85, 20.0},   /* pitch, +-50 deg */
    {-0.8727, 0.8727, 0.47, 0.85, 20.0},   /* yaw */
    {-1.5708, 1.5708, 0.0, 0.0, 40.0},     /* twist: not actuated here */
    {0.0, 0.3491, 0.15, 0.32, 40.0},       /* grip, 0..20 deg */
};

static hl_device* acme_create(const char* const* keys, const char* const* values, size_t count, char* error,
                              size_t error_size) {
  hl_device* d = calloc(1, sizeof *d);
  size_t i;
  int j;
  if (d == NULL) {
    snprintf(error, error_size, "out of memory");
    return NULL;
  }
  snprintf(d->port, sizeof d->port, "%s", "/dev/null");
  for (i = 0; i < count; ++i) {
    if (strcmp(keys[i], "port") == 0) {
      snprintf(d->port, sizeof d->port, "%s", values[i]);
    } else {
      /* Name the key and what is allowed: the operator reads this. */
      snprintf(error, error_size, "'%s' is not an option of the acme device; it takes port=PATH", keys[i]);
      free(d);
      return NULL;
    }
  }
  for (i = 0; i < HL_DEVICE_NUM_INSTRUMENTS; ++i)
    for (j = 0; j < HL_DEVICE_NUM_JOINTS; ++j) d->ratings.joint[i][j] = kJoint[j];
  atomic_init(&d->halted, 0);
  return d;
}

static hl_device_status acme_configure(hl_device* d, double nominal_rate_Hz, uint64_t seed) {
  (void)seed; /* hardware has nothing random */
  if (d->active) return HL_DEVICE_INVALID_CONFIG;
  if (!(nominal_rate_Hz >= 150.0 && nominal_rate_Hz <= 2000.0)) return HL_DEVICE_INVALID_CONFIG;
  /* BUS: open d->port, check the firmware version, set up the bus cycle for
   * nominal_rate_Hz. Return HL_DEVICE_READ_FAILED if the device does not answer. */
  d->rate_Hz = nominal_rate_Hz;
  d->configured = 1;
  return HL_DEVICE_OK;
}

static hl_device_status acme_ratings(const hl_device* d, hl_device_ratings* out) {
  /* BUS (optional): devices that store their limits read them in configure(). */
  *out = d->ratings;
  return HL_DEVICE_OK;
}

static hl_device_status acme_activate(hl_device* d, const hl_device_clock* clock) {
  int homed = 1;
  (void)clock; /* hardware runs on its own time */
  if (!d->configured) return HL_DEVICE_NOT_CONFIGURED;
  /* BUS: ask the device whether its encoders are homed. */
  if (!homed) return HL_DEVICE_NOT_CALIBRATED;
  /* BUS: command zero force, then enable the amplifiers. */
  atomic_store(&d->halted, 0);
  d->active = 1;
  return HL_DEVICE_OK;
}

static hl_device_status acme_read(hl_device* d, hl_device_reading* reading) {
  int i, j;
  if (!d->active) return HL_DEVICE_NOT_ACTIVE;
  /* BUS: one transfer that returns the encoder counts of both instruments;
   * convert counts to m and rad in HapticLab's joint order. On a bus error
   * return HL_DEVICE_READ_FAILED; HapticLab commands zero force and aborts
   * the trial. This skeleton reports a device resting mid-range. */
  for (i = 0; i < HL_DEVICE_NUM_INSTRUMENTS; ++i)
    for (j = 0; j < HL_DEVICE_NUM_JOINTS; ++j)
      reading->position[i][j] = 0.5 * (kJoint[j].min_position + kJoint[j].max_position);
  reading->device_time_s = NAN; /* or the device's own timestamp [s] */
  return HL_DEVICE_OK;
}

static double clip(double force, double peak) { return force > peak ? peak : (force < -peak ? -peak : force); }

static hl_device_status acme_write(hl_device* d, const hl_device_command* command) {
  double force[HL_DEVICE_NUM_INSTRUMENTS][HL_DEVICE_NUM_JOINTS];
  int i, j;
  if (!d->active) return HL_DEVICE_NOT_ACTIVE;
  for (i = 0; i < HL_DEVICE_NUM_INSTRUMENTS; ++i)
    for (j = 0; j < HL_DEVICE_NUM_JOINTS; ++j)
      force[i][j] = atomic_load(&d->halted) ? 0.0 : clip(command->force[i][j], d->ratings.joint[i][j].peak_force);
  /* BUS: convert force[][] to motor currents and send them. On failure
   * return HL_DEVICE_WRITE_FAILED. */
  (void)force;
  return HL_DEVICE_OK;
}

static hl_device_status acme_deactivate(hl_device* d) {
  /* BUS: command zero force, then disable the amplifiers. */
  atomic_store(&d->halted, 1);
  d->active = 0;
  return HL_DEVICE_OK;
}

static void acme_halt(hl_device* d) {
  /* Any thread, while read()/write() may run: no bus transfer that could
   * interleave with the loop's unless the bus allows it. The flag makes the
   * next write() send zero; BUS (if the hardware has one): drop the
   * amplifier enable line here. */
  atomic_store(&d->halted, 1);
}

static const char* acme_name(const hl_device* d) {
  (void)d;
  return "acme";
}

static void acme_destroy(hl_device* d) {
  if (d->active) acme_deactivate(d);
  /* BUS: close the port. */
  free(d);
}

static const hl_device_plugin kAcme = {
    HL_DEVICE_PLUGIN_ABI_VERSION, sizeof(hl_device_plugin),
    acme_create, acme_configure, acme_ratings, acme_activate, acme_read, acme_write, acme_deactivate,
    acme_halt, acme_name, acme_destroy,
    NULL /* hardware: no simulation extension */
};

const hl_device_plugin* hl_device_plugin_entry(void) { return &kAcme; }

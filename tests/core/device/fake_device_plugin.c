/*
 * A fake hardware device plugin for the tests: it reads a fixed pose and
 * misbehaves on request. Written in C, against the installed-style header,
 * as a lab's plugin would be. Options:
 *   fault=none|crash_in_configure|hang_in_configure|not_calibrated|nan_read|invalid_ratings|exit_in_create|jump|
 *         crash_in_read|crash_in_write|hang_in_read|slow_write|fail_deactivate|hang_in_deactivate|end_of_data|
 *         unknown_status|unfilled_read
 *     (jump: from the 101st read on, the left insertion reads 1 m further, as a slipped encoder would;
 *      crash_in_read, crash_in_write: SIGSEGV in that call once `after` calls of it have returned;
 *      hang_in_read: from then on read() does not return for hang_ms (0: never);
 *      slow_write: every write() takes write_delay_us, as a device on a slow bus would;
 *      fail_deactivate: deactivate() answers HL_DEVICE_WRITE_FAILED (the amplifiers would not switch off);
 *      hang_in_deactivate: deactivate() does not return for hang_ms (0: never);
 *      end_of_data: read() answers HL_DEVICE_END_OF_DATA once `after` reads have returned, which only a
 *      replay may say;
 *      unknown_status: read() answers 42, no hl_device_status, once `after` reads have returned;
 *      unfilled_read: read() answers HL_DEVICE_OK without writing the reading, once `after` reads have
 *      returned, as a driver that returns early on "no new frame" would)
 *   after=N          calls that behave before a crash_in_* or hang_in_read fault strikes (default 200)
 *   hang_ms=N        how long hang_in_read or hang_in_deactivate blocks (default 0: for ever)
 *   write_delay_us=N how long slow_write's write() takes (default 5000)
 *   name=TEXT        what name() answers (default "fake"), e.g. one with control characters
 *   report=PATH   at destroy and at every halt, write "writes N nonzero_writes M max_abs_force F halts H" to
 *                 PATH (at halt too, since a process that crashed never destroys its device)
 * Built three times (tests/core/device/CMakeLists.txt): as is, with
 * FAKE_ABI_VERSION=2, and with FAKE_NO_ENTRY (no entry point).
 */
#include <hapticlab/device_plugin.h>

#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#ifndef FAKE_ABI_VERSION
#define FAKE_ABI_VERSION HL_DEVICE_PLUGIN_ABI_VERSION
#endif

enum fault {
  NONE, CRASH_IN_CONFIGURE, HANG_IN_CONFIGURE, NOT_CALIBRATED, NAN_READ, INVALID_RATINGS, JUMP,
  CRASH_IN_READ, CRASH_IN_WRITE, HANG_IN_READ, SLOW_WRITE, FAIL_DEACTIVATE, HANG_IN_DEACTIVATE, END_OF_DATA,
  UNKNOWN_STATUS, UNFILLED_READ
};

struct hl_device {
  enum fault fault;
  char report[512];
  char name[128];
  int configured, active;
  long reads, writes, nonzero_writes, halts;
  double max_abs_force;
  long after, hang_ms, write_delay_us;
};

/* A non-negative whole number option, or -1. */
static long whole_number(const char* text) {
  char* end = NULL;
  long v = strtol(text, &end, 10);
  return (end == text || *end != '\0' || v < 0) ? -1 : v;
}

static void sleep_us(long us) {
  struct timespec ts;
  ts.tv_sec = us / 1000000;
  ts.tv_nsec = (us % 1000000) * 1000;
  while (nanosleep(&ts, &ts) != 0) {
  }
}

/* The fixed pose: inside the workstation's range on every joint. */
static const double kPose[HL_DEVICE_NUM_JOINTS] = {0.05, 0.1, -0.1, 0.0, 0.2};

static hl_device* fake_create(const char* const* keys, const char* const* values, size_t count, char* error,
                              size_t error_size) {
  hl_device* d = calloc(1, sizeof *d);
  size_t i;
  if (d == NULL) return NULL;
  d->after = 200;
  d->write_delay_us = 5000;
  for (i = 0; i < count; ++i) {
    if (strcmp(keys[i], "fault") == 0) {
      const char* v = values[i];
      if (strcmp(v, "none") == 0) d->fault = NONE;
      else if (strcmp(v, "crash_in_configure") == 0) d->fault = CRASH_IN_CONFIGURE;
      else if (strcmp(v, "hang_in_configure") == 0) d->fault = HANG_IN_CONFIGURE;
      else if (strcmp(v, "not_calibrated") == 0) d->fault = NOT_CALIBRATED;
      else if (strcmp(v, "nan_read") == 0) d->fault = NAN_READ;
      else if (strcmp(v, "invalid_ratings") == 0) d->fault = INVALID_RATINGS;
      else if (strcmp(v, "jump") == 0) d->fault = JUMP;
      else if (strcmp(v, "crash_in_read") == 0) d->fault = CRASH_IN_READ;
      else if (strcmp(v, "crash_in_write") == 0) d->fault = CRASH_IN_WRITE;
      else if (strcmp(v, "hang_in_read") == 0) d->fault = HANG_IN_READ;
      else if (strcmp(v, "slow_write") == 0) d->fault = SLOW_WRITE;
      else if (strcmp(v, "fail_deactivate") == 0) d->fault = FAIL_DEACTIVATE;
      else if (strcmp(v, "hang_in_deactivate") == 0) d->fault = HANG_IN_DEACTIVATE;
      else if (strcmp(v, "end_of_data") == 0) d->fault = END_OF_DATA;
      else if (strcmp(v, "unknown_status") == 0) d->fault = UNKNOWN_STATUS;
      else if (strcmp(v, "unfilled_read") == 0) d->fault = UNFILLED_READ;
      else if (strcmp(v, "exit_in_create") == 0) exit(7);
      else {
        snprintf(error, error_size, "fault: '%s' is not a fault of the fake device", v);
        free(d);
        return NULL;
      }
    } else if (strcmp(keys[i], "report") == 0) {
      snprintf(d->report, sizeof d->report, "%s", values[i]);
    } else if (strcmp(keys[i], "name") == 0) {
      snprintf(d->name, sizeof d->name, "%s", values[i]);
    } else if (strcmp(keys[i], "after") == 0 || strcmp(keys[i], "hang_ms") == 0 ||
               strcmp(keys[i], "write_delay_us") == 0) {
      const long v = whole_number(values[i]);
      if (v < 0) {
        snprintf(error, error_size, "%s: '%s' is not a whole number >= 0", keys[i], values[i]);
        free(d);
        return NULL;
      }
      if (keys[i][0] == 'a') d->after = v;
      else if (keys[i][0] == 'h') d->hang_ms = v;
      else d->write_delay_us = v;
    } else {
      snprintf(error, error_size,
               "'%s' is not an option of the fake device; it takes fault, report, after, hang_ms, write_delay_us",
               keys[i]);
      free(d);
      return NULL;
    }
  }
  return d;
}

static hl_device_status fake_configure(hl_device* d, double nominal_rate_Hz, uint64_t seed) {
  (void)seed;
  if (d->fault == CRASH_IN_CONFIGURE) raise(SIGSEGV);
  if (d->fault == HANG_IN_CONFIGURE)
    for (;;) pause(); /* a bus that never answers */
  if (!(nominal_rate_Hz >= 150.0 && nominal_rate_Hz <= 2000.0)) return HL_DEVICE_INVALID_CONFIG;
  d->configured = 1;
  return HL_DEVICE_OK;
}

static hl_device_status fake_ratings(const hl_device* d, hl_device_ratings* out) {
  int i, j;
  for (i = 0; i < HL_DEVICE_NUM_INSTRUMENTS; ++i)
    for (j = 0; j < HL_DEVICE_NUM_JOINTS; ++j) {
      hl_device_joint_rating r = {-1.0, 1.0, 0.1, 0.2, 10.0};
      out->joint[i][j] = r;
    }
  /* The right grip: peak below continuous. */
  if (d->fault == INVALID_RATINGS) out->joint[1][4].peak_force = 0.05;
  return HL_DEVICE_OK;
}

static hl_device_status fake_activate(hl_device* d, const hl_device_clock* clock) {
  (void)clock;
  if (!d->configured) return HL_DEVICE_NOT_CONFIGURED;
  if (d->fault == NOT_CALIBRATED) return HL_DEVICE_NOT_CALIBRATED;
  d->active = 1;
  return HL_DEVICE_OK;
}

static hl_device_status fake_read(hl_device* d, hl_device_reading* reading) {
  int i, j;
  if (!d->active) return HL_DEVICE_NOT_ACTIVE;
  if (d->fault == CRASH_IN_READ && d->reads >= d->after) raise(SIGSEGV);
  if (d->fault == HANG_IN_READ && d->reads >= d->after) {
    if (d->hang_ms == 0)
      for (;;) pause(); /* a bus transfer that never completes */
    sleep_us(d->hang_ms * 1000);
  }
  if (d->fault == END_OF_DATA && d->reads >= d->after) return HL_DEVICE_END_OF_DATA;
  if (d->fault == UNKNOWN_STATUS && d->reads >= d->after) return (hl_device_status)42;
  if (d->fault == UNFILLED_READ && d->reads >= d->after) return HL_DEVICE_OK;
  if (d->fault != JUMP) ++d->reads;
  for (i = 0; i < HL_DEVICE_NUM_INSTRUMENTS; ++i)
    for (j = 0; j < HL_DEVICE_NUM_JOINTS; ++j) reading->position[i][j] = kPose[j];
  /* Reported as fine: HapticLab must notice the NaN itself. */
  if (d->fault == NAN_READ) reading->position[0][1] = NAN;
  if (d->fault == JUMP && ++d->reads > 100) reading->position[0][0] = kPose[0] + 1.0;
  reading->device_time_s = NAN;
  return HL_DEVICE_OK;
}

static hl_device_status fake_write(hl_device* d, const hl_device_command* command) {
  int i, j, nonzero = 0;
  if (!d->active) return HL_DEVICE_NOT_ACTIVE;
  if (d->fault == CRASH_IN_WRITE && d->writes >= d->after) raise(SIGSEGV);
  if (d->fault == SLOW_WRITE) sleep_us(d->write_delay_us);
  for (i = 0; i < HL_DEVICE_NUM_INSTRUMENTS; ++i)
    for (j = 0; j < HL_DEVICE_NUM_JOINTS; ++j) {
      nonzero |= command->force[i][j] != 0.0;
      if (fabs(command->force[i][j]) > d->max_abs_force) d->max_abs_force = fabs(command->force[i][j]);
    }
  ++d->writes;
  d->nonzero_writes += nonzero;
  return HL_DEVICE_OK;
}

static hl_device_status fake_deactivate(hl_device* d) {
  d->active = 0;
  if (d->fault == FAIL_DEACTIVATE) return HL_DEVICE_WRITE_FAILED;
  if (d->fault == HANG_IN_DEACTIVATE) {
    if (d->hang_ms == 0)
      for (;;) pause(); /* an amplifier that never acknowledges */
    sleep_us(d->hang_ms * 1000);
  }
  return HL_DEVICE_OK;
}

static void write_report(const hl_device* d) {
  if (d->report[0] != '\0') {
    FILE* f = fopen(d->report, "w");
    if (f != NULL) {
      fprintf(f, "writes %ld nonzero_writes %ld max_abs_force %g halts %ld\n", d->writes, d->nonzero_writes,
              d->max_abs_force, d->halts);
      fclose(f);
    }
  }
}

static void fake_halt(hl_device* d) {
  ++d->halts;
  write_report(d);
}

static const char* fake_name(const hl_device* d) { return d->name[0] != '\0' ? d->name : "fake"; }

static void fake_destroy(hl_device* d) {
  write_report(d);
  free(d);
}

static const hl_device_plugin kPlugin = {FAKE_ABI_VERSION, sizeof(hl_device_plugin), fake_create, fake_configure,
                                         fake_ratings, fake_activate, fake_read, fake_write, fake_deactivate,
                                         fake_halt, fake_name, fake_destroy, NULL};

#ifndef FAKE_NO_ENTRY
const hl_device_plugin* hl_device_plugin_entry(void) { return &kPlugin; }
#else
/* Something exported, so the library loads but has no entry point. */
HL_DEVICE_PLUGIN_EXPORT const hl_device_plugin* not_the_entry_point(void) { return &kPlugin; }
#endif

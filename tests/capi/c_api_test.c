/* The C API, exercised from C as a device driver would. Plain asserts with
 * messages; exit code 0 means every check passed. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <hapticlab/hapticlab.h>

static int failures = 0;
#define CHECK(cond, ...)                                   \
  do {                                                     \
    if (!(cond)) {                                         \
      fprintf(stderr, "%s:%d: CHECK(%s) failed: ", __FILE__, __LINE__, #cond); \
      fprintf(stderr, __VA_ARGS__);                        \
      fprintf(stderr, "\n");                               \
      ++failures;                                          \
    }                                                      \
  } while (0)

static void test_bad_settings_give_a_message(void) {
  char error[512];
  hl_engine* e = hl_engine_create("{\"translation\": {\"friction\": {\"dynamic_level_N\": -1}}}",
                                  error, sizeof error);
  CHECK(e == NULL, "engine created from bad settings");
  CHECK(strstr(error, "translation.friction.dynamic_level_N") != NULL, "message: %s", error);
  CHECK(strstr(error, ">= 0") != NULL, "message: %s", error);
  e = hl_engine_create_from_file("/nonexistent/settings.json", error, sizeof error);
  CHECK(e == NULL && strstr(error, "cannot open") != NULL, "message: %s", error);
  /* A tiny buffer truncates, never overflows. */
  char tiny[8];
  memset(tiny, 'x', sizeof tiny);
  CHECK(hl_engine_create("not json", tiny, sizeof tiny) == NULL, "created");
  CHECK(tiny[7] == '\0', "not terminated");
}

static void test_friction_from_example_file(void) {
  char error[512];
  hl_engine* e = hl_engine_create_from_file(HAPTICLAB_EXAMPLES_DIR "/friction.json", error,
                                            sizeof error);
  CHECK(e != NULL, "create failed: %s", error);
  if (e == NULL) return;
  hl_input in;
  hl_output out;
  memset(&in, 0, sizeof in);
  in.insertion_m = 0.1;
  /* Insert at 50 mm/s with no VE force: after breakaway the device must push
   * back (negative insertion force) at the Table 3.1 level, 0.45 N, and the
   * world force points up the shaft (+z at zero angles). */
  for (int i = 0; i < 500; ++i) {
    in.dt_s = 0.001;
    in.insertion_m += 0.05 * 0.001;
    CHECK(hl_engine_update(e, 0, &in, &out) == HL_OK, "update failed");
  }
  CHECK(fabs(out.insertion_force_N + 0.45) < 1e-9, "insertion force %g", out.insertion_force_N);
  CHECK(fabs(out.displayed_force_N[2] - 0.45) < 1e-9, "world z %g", out.displayed_force_N[2]);
  CHECK(out.degraded_insertion_m == in.insertion_m, "positions changed without backlash");
  CHECK((out.status & HL_FAULT_MASK) == 0, "status %u", out.status);

  /* Non-finite input: zero force and a fault flag. */
  in.ve_force_N[0] = NAN;
  CHECK(hl_engine_update(e, 0, &in, &out) == HL_OK, "update failed");
  CHECK(out.status & HL_FAULT_NON_FINITE_INPUT, "status %u", out.status);
  CHECK(out.displayed_force_N[0] == 0 && out.displayed_force_N[1] == 0 &&
            out.displayed_force_N[2] == 0, "force not zero");

  /* Bad calls. */
  CHECK(hl_engine_update(e, 2, &in, &out) == HL_ERROR_INVALID_ARGUMENT, "instrument 2");
  CHECK(out.status & HL_FAULT_INVALID_ARGUMENT, "status %u", out.status);
  CHECK(hl_engine_update(NULL, 0, &in, &out) == HL_ERROR_INVALID_ARGUMENT, "null engine");

  /* Settings swap: bad text changes nothing, good text takes effect. */
  CHECK(hl_engine_set_settings(e, "{\"loop\": {\"hold_rate_Hz\": 1e9}}", error, sizeof error) ==
            HL_ERROR_SETTINGS, "accepted bad settings");
  CHECK(strstr(error, "loop.hold_rate_Hz") != NULL, "message: %s", error);
  CHECK(hl_engine_set_settings(e, "{\"name\": \"High Fidelity\"}", error, sizeof error) == HL_OK,
        "set failed: %s", error);
  in.ve_force_N[0] = 0.0;
  in.dt_s = 0.001;
  in.insertion_m += 0.00005;
  CHECK(hl_engine_update(e, 0, &in, &out) == HL_OK, "update failed");
  CHECK(out.insertion_force_N == 0.0, "friction still on: %g", out.insertion_force_N);
  hl_engine_destroy(e);
  hl_engine_destroy(NULL); /* allowed, like free() */
}

static double max_force_difference(const hl_output* a, const hl_output* b) {
  double d = fabs(a->insertion_force_N - b->insertion_force_N);
  d = fmax(d, fabs(a->pitch_torque_Nm - b->pitch_torque_Nm));
  d = fmax(d, fabs(a->yaw_torque_Nm - b->yaw_torque_Nm));
  for (int i = 0; i < 3; ++i) d = fmax(d, fabs(a->displayed_force_N[i] - b->displayed_force_N[i]));
  return d;
}

/* Where the degradations only add to the VE force, update(F_old) followed by
 * refresh_forces(F_new) must display what update(F_new) displays: two engines
 * in lockstep over the same motion, one told a stale force first. 1e-12 N is
 * rounding of the same sums (forces are ~1 N). */
static void test_refresh_forces_matches_update(const char* file) {
  char error[512];
  char path[512];
  snprintf(path, sizeof path, "%s/%s", HAPTICLAB_EXAMPLES_DIR, file);
  hl_engine* refreshed = hl_engine_create_from_file(path, error, sizeof error);
  hl_engine* direct = hl_engine_create_from_file(path, error, sizeof error);
  CHECK(refreshed != NULL && direct != NULL, "create %s failed: %s", file, error);
  if (refreshed == NULL || direct == NULL) return;
  double worst = 0.0, largest = 0.0;
  for (int i = 0; i < 2000; ++i) {
    const double t = 0.001 * i;
    hl_input in;
    memset(&in, 0, sizeof in);
    in.dt_s = 0.001;
    in.insertion_m = 0.12 + 0.03 * sin(2.0 * t);
    in.pitch_rad = 0.3 * sin(1.3 * t);
    in.yaw_rad = 0.2 * cos(0.7 * t);
    const double ve_new[3] = {0.4 * sin(3.0 * t), -0.3, 0.8 * cos(2.0 * t)};
    hl_input stale = in;
    stale.ve_force_N[0] = 0.5;
    stale.ve_force_N[1] = 0.1 * i;
    stale.ve_force_N[2] = -0.7;
    memcpy(in.ve_force_N, ve_new, sizeof ve_new);
    hl_output a, b;
    CHECK(hl_engine_update(refreshed, 1, &stale, &a) == HL_OK, "update failed");
    CHECK(hl_engine_refresh_forces(refreshed, 1, ve_new, &a) == HL_OK, "refresh failed");
    CHECK(hl_engine_update(direct, 1, &in, &b) == HL_OK, "update failed");
    worst = fmax(worst, max_force_difference(&a, &b));
    largest = fmax(largest, fabs(b.displayed_force_N[2]));
    CHECK(a.status == b.status, "%s update %d: status %u vs %u", file, i, a.status, b.status);
  }
  CHECK(worst < 1e-12, "%s: refreshed force differs by %g N", file, worst);
  CHECK(largest > 0.3, "%s: the VE force never reached the device (%g N)", file, largest);
  hl_engine_destroy(refreshed);
  hl_engine_destroy(direct);
}

static void test_refresh_forces_edge_cases(void) {
  char error[512];
  hl_engine* e = hl_engine_create("{\"name\": \"High Fidelity\"}", error, sizeof error);
  CHECK(e != NULL, "create failed: %s", error);
  if (e == NULL) return;
  hl_input in;
  hl_output out;
  memset(&in, 0, sizeof in);
  in.dt_s = 0.001;
  in.insertion_m = 0.1;
  in.ve_force_N[2] = 0.2;
  CHECK(hl_engine_update(e, 0, &in, &out) == HL_OK, "update failed");
  const double ve[3] = {0.0, 0.0, 0.6};
  CHECK(hl_engine_refresh_forces(e, 0, ve, &out) == HL_OK, "refresh failed");
  CHECK(out.displayed_force_N[2] == 0.6, "high fidelity shows %g N, not the new 0.6 N",
        out.displayed_force_N[2]);
  /* Only once per update: a second call leaves out alone. */
  const double other[3] = {0.0, 0.0, 1.5};
  out.displayed_force_N[1] = 42.0;
  CHECK(hl_engine_refresh_forces(e, 0, other, &out) == HL_OK, "refresh failed");
  CHECK(out.displayed_force_N[2] == 0.6 && out.displayed_force_N[1] == 42.0,
        "second refresh wrote %g, %g N", out.displayed_force_N[1], out.displayed_force_N[2]);
  /* A failed update is never refreshed back to life, even when the update
   * before it was not refreshed. */
  CHECK(hl_engine_update(e, 0, &in, &out) == HL_OK, "update failed");
  CHECK(hl_engine_update(e, 0, NULL, &out) == HL_ERROR_INVALID_ARGUMENT, "null input");
  CHECK(hl_engine_refresh_forces(e, 0, ve, &out) == HL_OK, "refresh failed");
  CHECK(out.displayed_force_N[2] == 0.0 && (out.status & HL_FAULT_INVALID_ARGUMENT),
        "refresh after a failed update: %g N, status %u", out.displayed_force_N[2], out.status);
  /* Non-finite VE force: zero force and the fault flag. */
  CHECK(hl_engine_update(e, 0, &in, &out) == HL_OK, "update failed");
  const double bad[3] = {0.0, NAN, 0.1};
  CHECK(hl_engine_refresh_forces(e, 0, bad, &out) == HL_OK, "refresh failed");
  CHECK(out.status & HL_FAULT_NON_FINITE_INPUT, "status %u", out.status);
  CHECK(out.displayed_force_N[0] == 0 && out.displayed_force_N[1] == 0 &&
            out.displayed_force_N[2] == 0, "force not zero");
  /* Bad calls leave out alone. */
  out.insertion_force_N = 42.0;
  CHECK(hl_engine_refresh_forces(e, 2, ve, &out) == HL_ERROR_INVALID_ARGUMENT, "instrument 2");
  CHECK(hl_engine_refresh_forces(NULL, 0, ve, &out) == HL_ERROR_INVALID_ARGUMENT, "null engine");
  CHECK(hl_engine_refresh_forces(e, 0, NULL, &out) == HL_ERROR_INVALID_ARGUMENT, "null force");
  CHECK(hl_engine_refresh_forces(e, 0, ve, NULL) == HL_ERROR_INVALID_ARGUMENT, "null out");
  CHECK(out.insertion_force_N == 42.0, "a bad call wrote to out");
  hl_engine_destroy(e);
}

/* Ramp-in: a constant VE force of 2 N down the shaft (High Fidelity shows
 * it as is) comes out scaled by t / 0.3 s, t the sum of the earlier
 * updates' dt (the first update commands exactly 0, as docs/safety.md
 * says), then in full. */
static void test_ramp_in_scales_force_by_elapsed_time(void) {
  char error[512];
  hl_engine* e = hl_engine_create_from_file(HAPTICLAB_EXAMPLES_DIR "/high_fidelity.json", error, sizeof error);
  CHECK(e != NULL, "create failed: %s", error);
  if (e == NULL) return;
  CHECK(hl_engine_set_ramp_in(e, -1.0) == HL_ERROR_INVALID_ARGUMENT, "negative ramp accepted");
  CHECK(hl_engine_set_ramp_in(NULL, 0.3) == HL_ERROR_INVALID_ARGUMENT, "NULL engine accepted");
  CHECK(hl_engine_set_ramp_in(e, 0.3) == HL_OK, "ramp refused");
  hl_input in;
  hl_output out;
  memset(&in, 0, sizeof in);
  in.insertion_m = 0.1;
  in.ve_force_N[2] = 2.0;
  double first = -1.0, at_150ms = -1.0, at_400ms = -1.0;
  unsigned status_150ms = 0, status_400ms = 0;
  for (int k = 1; k <= 400; ++k) {
    in.dt_s = 0.001;
    CHECK(hl_engine_update(e, 0, &in, &out) == HL_OK, "update failed");
    if (k == 1) first = out.displayed_force_N[2];
    if (k == 150) { at_150ms = out.displayed_force_N[2]; status_150ms = out.status; }
    if (k == 400) { at_400ms = out.displayed_force_N[2]; status_400ms = out.status; }
  }
  /* Update 1 at t = 0: nothing; update 151 at t = 150 ms: half; after 300 ms: all of it. */
  CHECK(first == 0.0, "first update %g N, not 0", first);
  CHECK(fabs(at_150ms - 2.0 * 149.0 / 300.0) < 1e-9 && (status_150ms & HL_RAMPING), "at update 150 %g N, status %u",
        at_150ms, status_150ms);
  CHECK(fabs(at_400ms - 2.0) < 1e-9 && !(status_400ms & HL_RAMPING), "at 400 ms %g N, status %u", at_400ms,
        status_400ms);
  hl_engine_destroy(e);
}

/* Joint-to-tip kinematics worked out by hand from eq. 2.20. */
/* Fixed settings: no other settings, no shorter ramp (a study's trial). */
static void test_fixed_settings_refuse_a_change(void) {
  char error[256];
  hl_engine* e = hl_engine_create("{}", error, sizeof error);
  CHECK(e != NULL, "create failed: %s", error);
  CHECK(hl_engine_set_settings(e, "{}", error, sizeof error) == HL_OK, "unfixed: %s", error);
  CHECK(hl_engine_set_ramp_in(e, 0.3) == HL_OK, "ramp");
  hl_engine_fix_settings(e);
  hl_engine_fix_settings(NULL);
  CHECK(hl_engine_set_settings(e, "{}", error, sizeof error) == HL_ERROR_SETTINGS, "fixed settings changed");
  CHECK(strstr(error, "settings are fixed") != NULL, "message: %s", error);
  CHECK(hl_engine_set_ramp_in(e, 0.0) == HL_ERROR_INVALID_ARGUMENT, "ramp removed");
  CHECK(hl_engine_set_ramp_in(e, 1.0) == HL_OK, "a longer ramp refused");
  hl_engine_destroy(e);
}

static void test_tip_position(void) {
  double tip[3];
  const double pi = 3.14159265358979323846;
  CHECK(hl_tip_position(0.1, 0.0, 0.0, NULL) == HL_ERROR_INVALID_ARGUMENT, "NULL tip accepted");
  CHECK(hl_tip_position(0.1, 0.0, 0.0, tip) == HL_OK, "tip refused");
  CHECK(tip[0] == 0.0 && tip[1] == 0.0 && tip[2] == -0.1, "straight down: %g %g %g", tip[0], tip[1], tip[2]);
  /* pitch 30 deg: y = 0.1 sin 30 = 0.05, z = -0.1 cos 30. */
  CHECK(hl_tip_position(0.1, pi / 6.0, 0.0, tip) == HL_OK, "tip refused");
  CHECK(fabs(tip[0]) < 1e-15 && fabs(tip[1] - 0.05) < 1e-15 && fabs(tip[2] + 0.1 * cos(pi / 6.0)) < 1e-15,
        "pitch 30 deg: %g %g %g", tip[0], tip[1], tip[2]);
  /* yaw 90 deg, pitch 60 deg: x = 0.2 cos 60 = 0.1, y = 0.2 sin 60, z = 0. */
  CHECK(hl_tip_position(0.2, pi / 3.0, pi / 2.0, tip) == HL_OK, "tip refused");
  CHECK(fabs(tip[0] - 0.1) < 1e-15 && fabs(tip[1] - 0.2 * sin(pi / 3.0)) < 1e-15 && fabs(tip[2]) < 1e-15,
        "yaw 90, pitch 60 deg: %g %g %g", tip[0], tip[1], tip[2]);
}

int main(void) {
  test_tip_position();
  CHECK(strlen(hl_version()) > 0, "no version");
  test_bad_settings_give_a_message();
  test_friction_from_example_file();
  test_refresh_forces_matches_update("friction.json");
  test_refresh_forces_matches_update("cogging.json");
  test_refresh_forces_matches_update("force_saturation.json");
  test_refresh_forces_edge_cases();
  test_ramp_in_scales_force_by_elapsed_time();
  test_fixed_settings_refuse_a_change();
  if (failures) {
    fprintf(stderr, "c_api_test: %d check(s) failed\n", failures);
    return 1;
  }
  printf("c_api_test: all checks passed\n");
  return 0;
}

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

int main(void) {
  CHECK(strlen(hl_version()) > 0, "no version");
  test_bad_settings_give_a_message();
  test_friction_from_example_file();
  if (failures) {
    fprintf(stderr, "c_api_test: %d check(s) failed\n", failures);
    return 1;
  }
  printf("c_api_test: all checks passed\n");
  return 0;
}

/*
 * How a device driver uses HapticLab's C API (thesis 2.2.7: the driver calls
 * the degradation library on every update; the VE needs no change).
 *
 * This stand-in "driver" has a fake device (a hand moving the left
 * instrument in and out) and a fake VE (a soft tissue surface 12 cm deep).
 * Per update it: reads the device, measures dt, asks the engine to degrade,
 * hands the degraded positions to the VE, puts the VE's force for them
 * through the engine, and commands the displayed force.
 *
 *   usage: hapticlab_c_driver SETTINGS.json [seconds]
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include <hapticlab/hapticlab.h>

/* Fake VE: tissue surface at 12 cm insertion, 200 N/m, pushes back up the
 * shaft. It only ever sees the degraded insertion (backlash shows here). */
static void ve_force(double degraded_insertion_m, double force_N[3]) {
  const double depth_m = degraded_insertion_m - 0.12;
  force_N[0] = force_N[1] = 0.0;
  force_N[2] = depth_m > 0 ? 200.0 * depth_m : 0.0; /* +z: out of the patient */
}

int main(int argc, char** argv) {
  if (argc < 2) {
    fprintf(stderr, "usage: %s SETTINGS.json [seconds]\n", argv[0]);
    return 2;
  }
  const double seconds = argc > 2 ? atof(argv[2]) : 2.0;
  char error[1024];
  hl_engine* engine = hl_engine_create_from_file(argv[1], error, sizeof error);
  if (engine == NULL) {
    fprintf(stderr, "hapticlab: %s\n", error);
    return 1;
  }
  printf("hapticlab %s, settings %s\n", hl_version(), argv[1]);

  double t = 0.0, peak_N = 0.0, degraded_m = 0.1;
  unsigned faults = 0;
  const double dt = 0.001; /* a real driver measures this on every update */
  for (int i = 0; t < seconds; ++i, t += dt) {
    hl_input in = {0};
    in.dt_s = dt;
    in.insertion_m = 0.11 + 0.02 * sin(2.0 * 3.14159265358979 * t); /* read the device */
    in.pitch_rad = 0.1;
    in.yaw_rad = -0.05;
    ve_force(degraded_m, in.ve_force_N); /* VE force from last update's VE pose */

    hl_output out;
    if (hl_engine_update(engine, 0, &in, &out) != HL_OK) return 1;
    degraded_m = out.degraded_insertion_m; /* -> VE */
    /* The VE steps on the new degraded pose; its force reaches the device in
     * this update rather than the next. */
    double ve_now_N[3];
    ve_force(degraded_m, ve_now_N);
    if (hl_engine_refresh_forces(engine, 0, ve_now_N, &out) != HL_OK) return 1;
    if (out.status & HL_FAULT_MASK) ++faults;
    /* -> device: command out.displayed_force_N (world) or the joint values. */
    const double f = sqrt(out.displayed_force_N[0] * out.displayed_force_N[0] +
                          out.displayed_force_N[1] * out.displayed_force_N[1] +
                          out.displayed_force_N[2] * out.displayed_force_N[2]);
    if (f > peak_N) peak_N = f;
  }
  printf("%.1f s simulated, peak displayed force %.3f N, %u faulted updates\n", seconds, peak_N,
         faults);
  hl_engine_destroy(engine);
  return faults == 0 ? 0 : 1;
}

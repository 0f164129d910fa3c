/*
 * An application that owns its haptic loop runs a HapticLab study through
 * the study API (hapticlab/study.h). It stands in for a lab's simulator:
 *
 *   - its own toy VE, "peg touch": a target point 5 cm down the left
 *     instrument's shaft; the tip touches it while it is within 5 mm of it
 *     (a spring of 200 N/m pushes back); the task is complete when the third
 *     touch ends;
 *   - a scripted hand instead of a device: the left tool goes in at
 *     0.1 mm per update, then moves up and down between 40 and 49 mm
 *     insertion; the right tool rests at 10 mm;
 *   - a synthetic 1 kHz loop clock: it runs as fast as the CPU allows, and
 *     every time it logs is its own (docs/ve_events.md).
 *
 * Per update: hand -> hl_engine_update (the trial's degradations) -> VE on
 * the degraded positions -> hl_engine_refresh_forces -> "command" the force
 * -> hl_study_log_sample; the VE's events go to hl_study_log_event.
 *
 * Create the study first, then run every trial of a participant:
 *     hapticlab study create --protocol external_peg_touch.json --db study.db
 *     hapticlab_external_app study.db P01
 * Running it again resumes where it stopped (after a crash too).
 *
 *   usage: hapticlab_external_app DB PARTICIPANT [--stall-after N] [--time-limit S]
 *   --stall-after N: in the first trial of this run, stop updating after N
 *     samples and hang (a VE that froze; for the crash test, which kills it).
 *   --time-limit S: a trial still running at S seconds of loop time is ended
 *     with HL_TRIAL_TIME_LIMIT (default 10).
 *   Ctrl-C: operator stop (force zero from the next update, trial aborted
 *     and re-queued, session closed).
 */
#define _POSIX_C_SOURCE 200809L

#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <hapticlab/study.h>

#define RATE_HZ 1000.0
#define TARGET_INSERTION_M 0.050 /* along the left shaft: tip at (0, 0, -0.05) */
#define TOUCH_RADIUS_M 0.005
#define SPRING_N_PER_M 200.0
#define TOUCHES_TO_COMPLETE 3
#define INSERTION_EVENT_M 0.020 /* docs/ve_events.md: insertion_passed at 20 mm */

static volatile sig_atomic_t operator_stop = 0;
static void on_sigint(int sig) {
  (void)sig;
  operator_stop = 1; /* hl_study_request_stop takes a lock: called from the loop, not here */
}

/* The scripted hand: left insertion at update k [m]. In at 0.1 mm per update
 * from 10.05 mm; from 49.05 mm (k = 390) a triangle wave down to 40.05 mm
 * and back, 180 updates per period. The half-step offsets keep every
 * threshold (20 mm, 45 mm) midway between two updates. */
static double hand_insertion_m(long k) {
  const double step_m = 1e-4;
  if (k <= 390) return 0.01005 + step_m * (double)k;
  const long phase = (k - 390) % 180;
  return phase <= 90 ? 0.04905 - step_m * (double)phase : 0.04005 + step_m * (double)(phase - 90);
}

/* The toy VE's state of one instrument. */
typedef struct {
  double insertion_m; /* degraded, last update */
  double tip_m[3];
  int in_contact;
  int inside_20mm; /* insertion above INSERTION_EVENT_M */
} tool_state;

static int check(int rc, const char* what, const char* error) {
  if (rc < 0) fprintf(stderr, "external_app: %s failed (%d): %s\n", what, rc, error);
  return rc;
}

/* The toy VE on one instrument's degraded position: its insertion and
 * contact events, and its force (a spring pushing the tip back out of the
 * target) into ve_force_N. Returns whether the tool is in contact; sets
 * *task_done when the last touch ends. */
static int ve_update(hl_study* study, tool_state* s, int i, double t_s, const hl_output* out,
                     double ve_force_N[3], int* touches, int* task_done) {
  s->insertion_m = out->degraded_insertion_m;
  /* The scripted hand keeps pitch = yaw = 0: the tip goes down -z from the pivot. */
  hl_tip_position(out->degraded_insertion_m, out->degraded_pitch_rad, out->degraded_yaw_rad, s->tip_m);
  const int inside = s->insertion_m >= INSERTION_EVENT_M;
  if (inside && !s->inside_20mm) hl_study_log_event(study, t_s, HL_EVENT_INSERTION_PASSED, i, 0);
  if (!inside && s->inside_20mm) hl_study_log_event(study, t_s, HL_EVENT_INSERTION_WITHDRAWN, i, 0);
  s->inside_20mm = inside;

  const double depth_m = s->insertion_m - (TARGET_INSERTION_M - TOUCH_RADIUS_M);
  const int contact = i == 0 && depth_m > 0.0;
  ve_force_N[0] = ve_force_N[1] = 0.0;
  ve_force_N[2] = contact ? SPRING_N_PER_M * depth_m : 0.0; /* +z: back out of the patient */
  if (contact && !s->in_contact) {
    hl_study_log_event(study, t_s, HL_EVENT_CONTACT_START, i, *touches);
    ++*touches;
  }
  if (!contact && s->in_contact) hl_study_log_event(study, t_s, HL_EVENT_CONTACT_END, i, *touches - 1);
  if (!contact && s->in_contact && *touches >= TOUCHES_TO_COMPLETE) *task_done = 1;
  s->in_contact = contact;
  return contact;
}

/* One instrument's part of the sample to log (the tip's velocity by
 * difference from the previous update, 0 on the first). */
static void log_instrument(hl_sample_instrument* log, double raw_m, const hl_output* out, const tool_state* s,
                           const double previous_tip[3], const double ve_force_N[3], int first, double dt_s) {
  log->raw_joints[0] = raw_m;
  log->degraded_joints[0] = out->degraded_insertion_m;
  log->degraded_joints[1] = out->degraded_pitch_rad;
  log->degraded_joints[2] = out->degraded_yaw_rad;
  for (int a = 0; a < 3; ++a) {
    log->tip_position_m[a] = s->tip_m[a];
    log->tip_velocity_m_per_s[a] = first ? 0.0 : (s->tip_m[a] - previous_tip[a]) / dt_s;
    log->ve_force_N[a] = ve_force_N[a];
    log->displayed_force_N[a] = out->displayed_force_N[a];
  }
  log->joint_force[0] = out->insertion_force_N;
  log->joint_force[1] = out->pitch_torque_Nm;
  log->joint_force[2] = out->yaw_torque_Nm;
  log->engine_status = out->status;
}

/* Runs one trial; returns the outcome for hl_study_end_trial (and its reason). */
static int run_trial(hl_study* study, const hl_trial* trial, long stall_after, double time_limit_s,
                     const char** reason) {
  tool_state tool[2];
  memset(tool, 0, sizeof tool);
  double ve_force_N[2][3] = {{0, 0, 0}, {0, 0, 0}};
  int touches = 0;
  const double dt_s = 1.0 / RATE_HZ;
  for (long k = 0;; ++k) {
    const double t_s = (double)k * dt_s;
    if (operator_stop) {
      hl_study_request_stop(study); /* zero force from the next update */
      *reason = "operator stop";    /* the study records it as the operator's abort */
      return HL_TRIAL_ABORTED;
    }
    if (t_s > time_limit_s) {
      *reason = "the application's limit";
      return HL_TRIAL_TIME_LIMIT;
    }
    if (stall_after >= 0 && k == stall_after) {
      printf("stalled in trial %lld after %ld samples\n", (long long)trial->trial_id, k);
      fflush(stdout);
      for (;;) pause(); /* a frozen VE: the crash test kills us here */
    }

    hl_sample sample;
    memset(&sample, 0, sizeof sample);
    sample.tick = (uint64_t)k;
    sample.t_s = t_s;
    sample.dt_s = dt_s;
    int task_done = 0;
    for (int i = 0; i < 2; ++i) {
      /* Device read (the scripted hand), then the degradations. */
      const double raw_m = i == 0 ? hand_insertion_m(k) : 0.010;
      hl_input in;
      memset(&in, 0, sizeof in);
      in.dt_s = dt_s;
      in.insertion_m = raw_m;
      memcpy(in.ve_force_N, ve_force_N[i], sizeof in.ve_force_N);
      hl_output out;
      if (hl_engine_update(trial->engine, i, &in, &out) != HL_OK) {
        *reason = "the engine refused an update";
        return HL_TRIAL_ABORTED;
      }

      /* The VE sees only the degraded position. */
      tool_state* s = &tool[i];
      const double previous_tip[3] = {s->tip_m[0], s->tip_m[1], s->tip_m[2]};
      const int contact = ve_update(study, s, i, t_s, &out, ve_force_N[i], &touches, &task_done);

      /* The VE's force for this update's positions, through the degradations. */
      hl_engine_refresh_forces(trial->engine, i, ve_force_N[i], &out);
      /* (a real application commands out.insertion_force_N etc. on its device here) */

      log_instrument(&sample.instrument[i], raw_m, &out, s, previous_tip, ve_force_N[i], k == 0, dt_s);
      sample.instrument[i].in_contact = contact;
    }
    hl_study_log_sample(study, &sample); /* never blocks; a full queue counts a drop */
    if (task_done) {
      hl_study_log_event(study, t_s, HL_EVENT_TASK_COMPLETE, -1, 0);
      return HL_TRIAL_COMPLETE;
    }
  }
}

int main(int argc, char** argv) {
  if (argc < 3) {
    fprintf(stderr, "usage: %s DB PARTICIPANT [--stall-after N] [--time-limit S]\n", argv[0]);
    return 2;
  }
  long stall_after = -1;
  double time_limit_s = 10.0;
  for (int a = 3; a + 1 < argc; a += 2) {
    if (strcmp(argv[a], "--stall-after") == 0) stall_after = atol(argv[a + 1]);
    else if (strcmp(argv[a], "--time-limit") == 0) time_limit_s = atof(argv[a + 1]);
    else {
      fprintf(stderr, "external_app: unknown option %s\n", argv[a]);
      return 2;
    }
  }
  struct sigaction sa;
  memset(&sa, 0, sizeof sa);
  sa.sa_handler = on_sigint;
  sigaction(SIGINT, &sa, NULL);

  char error[1024] = "";
  hl_study* study = hl_study_open(argv[1], error, sizeof error);
  if (study == NULL) {
    fprintf(stderr, "external_app: %s\n", error);
    return 1;
  }
  if (check(hl_study_start_session(study, argv[2], "external_app", error, sizeof error), "start session", error) < 0) {
    hl_study_close(study);
    return 1;
  }
  if (error[0] != '\0') printf("note: %s\n", error);

  int rc = 0;
  for (;;) {
    hl_trial trial;
    char setting[128]; /* operator console only: never shown to the participant */
    const int next = hl_study_next_trial(study, &trial, setting, sizeof setting, error, sizeof error);
    if (next == HL_STUDY_DONE || next == HL_STUDY_STOPPED) {
      printf("%s\n", next == HL_STUDY_DONE ? "schedule complete" : "stopped by the operator");
      break;
    }
    if (check(next, "next trial", error) < 0) {
      rc = 1;
      break;
    }
    /* Participant's screen: task and progress. Operator's console: the setting. */
    printf("trial %lld started: %s, trial %d of %d [operator: %s]\n", (long long)trial.trial_id, trial.task,
           trial.trial_number, trial.trial_count, setting);
    fflush(stdout);
    const char* reason = NULL;
    const int outcome = run_trial(study, &trial, stall_after, time_limit_s, &reason);
    stall_after = -1; /* only the first trial of a run */
    if (check(hl_study_end_trial(study, outcome, reason, error, sizeof error), "end trial", error) < 0) {
      rc = 1;
      break;
    }
    uint64_t dropped_samples = 0, dropped_events = 0;
    hl_study_dropped(study, &dropped_samples, &dropped_events);
    printf("trial %lld ended: %s (dropped %llu samples, %llu events)\n", (long long)trial.trial_id,
           outcome == HL_TRIAL_COMPLETE ? "complete" : "aborted", (unsigned long long)dropped_samples,
           (unsigned long long)dropped_events);
  }
  if (rc == 0 && check(hl_study_end_session(study, error, sizeof error), "end session", error) < 0) rc = 1;
  hl_study_close(study);
  return rc;
}

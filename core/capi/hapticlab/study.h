/*
 * HapticLab study API: run a HapticLab study from an application that owns
 * the haptic loop (a lab's own simulator on CHAI3D, H3D, SOFA, Unity...).
 *
 * The study itself is made with the command line first:
 *     hapticlab study create --protocol my_protocol.json --db study.db
 * (a protocol with "ve": "external" may name the lab's own tasks). The
 * application then, for one participant:
 *
 *     hl_study* s = hl_study_open("study.db", err, sizeof err);
 *     hl_study_start_session(s, "P01", err, sizeof err);
 *     while (hl_study_next_trial(s, &trial, setting, sizeof setting, err, sizeof err) == HL_OK) {
 *       ... run the task in its VE; on every haptic update:
 *           hl_engine_update(trial.engine, ...)      (the trial's degradations)
 *           hl_study_log_sample(s, &sample)           (never blocks)
 *           hl_study_log_event(s, t_s, HL_EVENT_CONTACT_START, 0, 0)   (when it happens)
 *       hl_study_end_trial(s, HL_TRIAL_COMPLETE, NULL, err, sizeof err);
 *     }
 *     hl_study_end_session(s, err, sizeof err);
 *     hl_study_close(s);
 *
 * Guarantees, the same as `hapticlab session run`:
 * - Trials come in schedule order. A trial left running by a crashed or
 *   killed application is aborted (its samples kept) when the participant's
 *   next session starts, and every aborted trial is re-queued at its place
 *   in the schedule; a complete trial never runs again. A trial ended with
 *   HL_TRIAL_TIME_LIMIT closes its slot (it is not re-queued).
 * - One live session per participant and database (a second one is refused
 *   with HL_ERROR_BUSY naming the process that holds it).
 * - Samples and events go through lock-free queues to a writer thread that
 *   stores them in the database; logging never blocks, allocates or does
 *   I/O. The queues hold HL_STUDY_SAMPLE_QUEUE_CAPACITY samples (16 s at
 *   1 kHz, so a writer held up by another station's commit loses nothing)
 *   and HL_STUDY_EVENT_QUEUE_CAPACITY events. A full queue drops the item
 *   and counts it (hl_study_dropped), and the counts are stored with the
 *   trial.
 * - A sample or event that cannot be stored as given (a tick that does not
 *   increase, an event type this header does not define, ...) is refused
 *   at the call with HL_ERROR_INVALID_ARGUMENT and counted
 *   (hl_study_rejected); the trial goes on, and the counts are stored with
 *   it (device counters rejected_samples, rejected_events).
 * - Blinding: hl_trial holds only what a participant may see. The setting's
 *   name is given separately, for the operator.
 *
 * Times: t_s of samples and events is the application's loop clock [s],
 * from the start of the trial (any origin, but one clock for samples and
 * events of a trial). The analysis reads the task window from the events;
 * docs/ve_events.md is the contract a VE must follow.
 *
 * Threads: hl_study_log_sample and hl_study_log_event are real-time safe;
 * call each from one thread at a time (the haptic loop). hl_study_request_stop
 * may be called from any thread at any time. Every other function: one
 * non-real-time thread, never concurrently with each other.
 *
 * Errors: every function returns HL_OK (0), a positive "nothing more"
 * code, or a negative HL_ERROR_*; those taking an error buffer write a
 * message there (truncated to error_size; an empty string on success). A
 * call out of order (a trial while one is open, a sample without a trial,
 * a session ended twice) returns HL_ERROR_STATE and changes nothing.
 */
#ifndef HAPTICLAB_STUDY_H_
#define HAPTICLAB_STUDY_H_

#include <stddef.h>
#include <stdint.h>

#include "hapticlab/hapticlab.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct hl_study hl_study;

/* Return codes (HL_OK, HL_ERROR_INVALID_ARGUMENT: hapticlab.h). */
#define HL_STUDY_DONE 1          /* hl_study_next_trial: the participant's schedule is complete */
#define HL_STUDY_STOPPED 2       /* hl_study_next_trial: the operator stopped the session */
#define HL_STUDY_DROPPED 3       /* hl_study_log_*: the queue was full; the item was dropped and counted */
#define HL_ERROR_STATE (-3)      /* called out of order; nothing changed */
#define HL_ERROR_DATABASE (-4)   /* the study database failed (missing, damaged, disk full) */
#define HL_ERROR_BUSY (-5)       /* the participant has a live session in another process */
#define HL_ERROR_STUDY (-6)      /* unknown participant, or a database without a study */

/* Capacity of the queues between the logging calls and the writer thread. */
#define HL_STUDY_SAMPLE_QUEUE_CAPACITY 16384
#define HL_STUDY_EVENT_QUEUE_CAPACITY 4096

/* Task events (docs/ve_events.md). instrument: 0 left, 1 right, -1 the task as a whole. */
#define HL_EVENT_INSERTION_PASSED 0    /* the tool's insertion rose through 20 mm */
#define HL_EVENT_INSERTION_WITHDRAWN 1 /* ... and fell back below it */
#define HL_EVENT_CONTACT_START 2       /* the tool tip started touching the task's object */
#define HL_EVENT_CONTACT_END 3         /* ... and stopped */
#define HL_EVENT_GRASP_START 4         /* a closed grasper holds something */
#define HL_EVENT_GRASP_END 5
#define HL_EVENT_TASK_COMPLETE 9       /* the task's goal is reached (instrument -1) */

/* How a trial ended (hl_study_end_trial). */
#define HL_TRIAL_COMPLETE 0    /* the task was done */
#define HL_TRIAL_ABORTED 1     /* not done (reason required): re-queued, runs again later */
#define HL_TRIAL_TIME_LIMIT 2  /* the application's time limit ran out: aborted, not re-queued */

/* What a participant may see of a trial. */
typedef struct hl_trial {
  int64_t trial_id;       /* the trial's row in the database */
  char task[128];         /* the protocol's task name, NUL-terminated */
  int repetition;         /* 1-based, of this setting and task */
  int trial_number;       /* k: this participant's complete trials + 1 */
  int trial_count;        /* N: trials in the participant's schedule */
  /* The trial's degradations, configured with its setting; owned by the
   * study, valid until hl_study_end_trial (or hl_study_close). Use it with
   * hl_engine_update / hl_engine_refresh_forces on the haptic loop. Its
   * settings and its 0.3 s ramp-in are fixed (hl_engine_fix_settings):
   * hl_engine_set_settings refuses, hl_engine_set_ramp_in takes only a
   * longer ramp. */
  hl_engine* engine;
} hl_trial;

/* One instrument of one haptic update: what `session run` logs. Units and
 * frames as hapticlab.h: joints insertion m, pitch/yaw/twist/grip rad;
 * positions and forces in the VE world frame. */
typedef struct hl_sample_instrument {
  double raw_joints[5];          /* as read from the device (unused joints: 0) */
  double degraded_joints[3];     /* hl_output degraded_* (insertion, pitch, yaw) */
  double tip_position_m[3];      /* VE tool tip */
  double tip_velocity_m_per_s[3];
  double ve_force_N[3];          /* force the VE applied to the tip */
  double displayed_force_N[3];   /* hl_output displayed_force_N */
  double joint_force[3];         /* hl_output insertion_force_N, pitch/yaw torque */
  uint32_t engine_status;        /* hl_output status */
  int in_contact;                /* non-zero while the tip touches the task's object */
} hl_sample_instrument;

typedef struct hl_sample {
  uint64_t tick;    /* 0-based update number, increasing within a trial; a jump is logged as missing updates */
  double t_s;       /* loop clock at the start of the update, s (finite) */
  double dt_s;      /* time since the previous update, s (finite) */
  int32_t device_status; /* the device's own status code, 0 = ok */
  hl_sample_instrument instrument[2]; /* 0 left, 1 right */
} hl_sample;

/*
 * Opens a study database made with `hapticlab study create` (nothing in it
 * changes until a session starts). NULL on failure, with the reason.
 */
HL_API hl_study* hl_study_open(const char* db_path, char* error, size_t error_size);

/*
 * Starts the participant's session: takes the participant's lock, recovers a
 * trial a dead session left running, re-queues aborted trials, records the
 * session (device: the application's name, e.g. "external"; may be NULL;
 * UTF-8 without control characters (C0, C1, line and paragraph separators,
 * bidirectional overrides), else HL_ERROR_INVALID_ARGUMENT; the
 * session's clock is recorded as "wall", the application's own).
 * On success the error buffer may hold a note for the operator (the
 * participant's previous session had died and was recovered).
 * A stop requested while no session was open (hl_study_request_stop) holds
 * for this session: its first hl_study_next_trial answers HL_STUDY_STOPPED.
 * HL_ERROR_STUDY for an unknown code (the message lists the study's codes),
 * HL_ERROR_BUSY when another live process runs this participant,
 * HL_ERROR_STATE when a session is already open on this handle.
 */
HL_API int hl_study_start_session(hl_study* study, const char* participant_code, const char* device,
                                  char* error, size_t error_size);

/*
 * Starts the next trial of the schedule: fills *trial and, if
 * operator_setting is not NULL, the name of the trial's setting.
 * THE SETTING NAME IS FOR THE OPERATOR ONLY: never show it to the
 * participant (the study is blinded). Returns HL_OK, HL_STUDY_DONE when no
 * trial is left, HL_STUDY_STOPPED after hl_study_request_stop, or
 * HL_ERROR_STATE without a session or while a trial is open.
 * HL_ERROR_DATABASE when the database failed, or when the trial's setting
 * no longer matches the digest stored with it (the file was edited: the
 * session is then ended as interrupted; put the setting back and start a
 * new session).
 */
HL_API int hl_study_next_trial(hl_study* study, hl_trial* trial, char* operator_setting,
                               size_t operator_setting_size, char* error, size_t error_size);

/*
 * Logs one haptic update of the open trial. Real-time safe: copies into a
 * lock-free queue. HL_OK, HL_STUDY_DROPPED (queue full; counted),
 * HL_ERROR_DATABASE once the trial's storage failed (a full disk: nothing
 * logged from then on is kept, and the trial's engine is halted, zero force;
 * end the trial, hl_study_end_trial says why),
 * HL_ERROR_STATE without an open trial, HL_ERROR_INVALID_ARGUMENT for NULL
 * and, counted in hl_study_rejected, for a tick not greater than the last
 * one accepted in this trial or not below INT64_MAX (the stored chunk's end,
 * one past its last tick, must fit in 64 signed bits), a t_s before the last
 * accepted one, a negative dt_s, a t_s or dt_s that is NaN or infinite, or
 * a joint, position, velocity or force that is NaN, infinite or beyond
 * +-3.4e38 (they are stored as float32, where it would become infinite) (the
 * sample is not stored; the trial goes on).
 */
HL_API int hl_study_log_sample(hl_study* study, const hl_sample* sample);

/*
 * Logs a task event of the open trial (HL_EVENT_*), at loop time t_s, of
 * instrument 0 or 1 (HL_EVENT_TASK_COMPLETE: -1, the task as a whole);
 * index: an item number >= 0 where the VE has several (0 otherwise).
 * Real-time safe. Return codes as hl_study_log_sample; a type other than
 * the HL_EVENT_* above, an instrument other than the type's, a negative
 * index or a non-finite t_s is HL_ERROR_INVALID_ARGUMENT, counted in
 * hl_study_rejected.
 */
HL_API int hl_study_log_event(hl_study* study, double t_s, int type, int instrument, int32_t index);

/* Samples and events of the open (or last) trial dropped because a queue was full. */
HL_API int hl_study_dropped(const hl_study* study, uint64_t* samples, uint64_t* events);

/* Samples and events of the open (or last) trial refused as invalid (HL_ERROR_INVALID_ARGUMENT). */
HL_API int hl_study_rejected(const hl_study* study, uint64_t* samples, uint64_t* events);

/*
 * Ends the open trial: stores what is still queued, then the outcome
 * (HL_TRIAL_*; reason: UTF-8 text, required for HL_TRIAL_ABORTED and not
 * blank; optional for HL_TRIAL_TIME_LIMIT, stored in its reason; none for
 * HL_TRIAL_COMPLETE, which has nowhere to store one: NULL or "". A reason
 * that breaks this is refused with HL_ERROR_INVALID_ARGUMENT, the trial
 * still open). The trial's hl_engine is destroyed. After
 * hl_study_request_stop the trial is recorded as aborted by the operator,
 * whatever outcome and reason are given. HL_TRIAL_COMPLETE or HL_TRIAL_TIME_LIMIT for
 * a trial of which no sample was logged (hl_study_log_sample never
 * answered HL_OK) is refused with HL_ERROR_STATE, the trial still open: it
 * would close its slot and have no metrics (HL_TRIAL_ABORTED re-queues it).
 * The trial's loop_timing record is made from the samples' dt_s: when
 * their mean period times the updates (ticks) disagrees with the time the
 * samples' t_s span by more than 10 % (a dt_s left at 0, or in ms), the
 * trial is stored as ended, with a loop_timing_mismatch event saying so,
 * and the error buffer holds that note although HL_OK is returned.
 * HL_ERROR_DATABASE when the database could not
 * be written: the trial is then aborted with its samples so far kept, and
 * the session is over (start a new one once the disk is fixed). The
 * trial's engine was halted (zero force, HL_HALTED) as soon as the writer
 * failed: nothing felt from then on would have been recorded.
 */
HL_API int hl_study_end_trial(hl_study* study, int outcome, const char* reason, char* error, size_t error_size);

/*
 * Operator stop, from any thread (a stop button, a signal handler's
 * thread): the open trial's hl_engine outputs zero force from its next
 * hl_engine_update on (status bit HL_HALTED), and no further trial starts.
 * The application should then end the trial (it is recorded as aborted by
 * the operator, with an operator_abort event at the last logged sample's
 * time, and re-queued) and end the session. Idempotent. The stop holds
 * until hl_study_end_session ends the session it stopped; one requested
 * while no session is open (before hl_study_start_session, or while it
 * runs), or one whose session was ended by the library (a storage failure,
 * an edited setting), stops the next session before its first trial. A
 * stop is never answered HL_OK and then forgotten.
 */
HL_API int hl_study_request_stop(hl_study* study);

/* Ends the session (HL_ERROR_STATE while a trial is open or without a session). */
HL_API int hl_study_end_session(hl_study* study, char* error, size_t error_size);

/*
 * Closes the handle. An open trial is aborted (re-queued) and an open
 * session ended as interrupted first. NULL is allowed.
 */
HL_API void hl_study_close(hl_study* study);

#ifdef __cplusplus
}
#endif

#endif /* HAPTICLAB_STUDY_H_ */

#include "sessions/staircase_planner.h"

#include <algorithm>

#include "core/settings/settings_json.h"
#include "db/sqlite_handle.h"

namespace hapticlab::sessions {

std::optional<analysis::StaircaseProgress> plan_next_staircase_trial(db::StudyDb& db, const db::StudyRow& study,
                                                                     std::int64_t participant_id) {
  std::optional<analysis::StaircaseProgress> progress = analysis::staircase_progress(db, study, participant_id);
  if (!progress || progress->state.finished) return progress;
  const double strength = progress->state.next_strength;
  NamedSettings base = db.setting(progress->base_setting_id);
  base.name = progress->base_name;
  const NamedSettings at = settings_at_strength(base, progress->spec.field, strength);

  db::Transaction tx(db.connection());
  std::int64_t setting_id = 0;
  for (const auto& [id, name] : db.settings(study.id))
    if (name == at.name) setting_id = id;
  if (setting_id == 0) setting_id = db.add_setting(study.id, at);
  int position = 0;
  int repetition = 1;
  for (const db::TrialRow& t : db.trials(study.id)) {
    if (t.participant_id != participant_id) continue;
    position = std::max(position, t.position);
    if (t.block == 0 && t.setting_id == setting_id) repetition = std::max(repetition, t.repetition + 1);
  }
  db.add_trial({participant_id, progress->spec.task, setting_id, repetition, 0, position + 1});
  tx.commit();
  return progress;
}

}  // namespace hapticlab::sessions

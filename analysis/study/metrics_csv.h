#pragma once
// The per-trial metrics CSV of `hapticlab analyze`: one row per analysed
// trial and hand, columns
//
//   trial_id,participant,[site,]task,setting,repetition,block,trial_number,status,
//   hand,task_start_s,task_end_s,completion_time_s,samples,force_samples,
//   force_median_N,force_p95_N,speed_median_m_per_s,path_length_m,note
//
// trial_number is the trial's position in the participant's schedule (the
// thesis' "trial number", 3.4.2.2). `site` is there only for a merged
// multi-site study (hapticlab study merge): the participant's site.
// completion_time_s belongs to the trial and repeats on both hands' rows.
// A missing value is an empty field, and `note` says why. Numbers are written in the shortest form that reads back
// to the same double (core/common/csv_format.h).
#include <filesystem>
#include <iosfwd>

#include "analysis/study/study_analysis.h"

namespace hapticlab::analysis {

void write_metrics_csv(const StudyAnalysis& analysis, std::ostream& out);
// Writes `path` (replacing it); throws DataError naming the path on failure.
void write_metrics_csv(const StudyAnalysis& analysis, const std::filesystem::path& path);

}  // namespace hapticlab::analysis

#pragma once
// The analysis of a dose-response study (protocol "dose", docs/protocols.md;
// docs/analysis.md, "Dose-response"): one degradation at several strengths
// beside the control.
//
//   per participant: the median of each strength's repetitions (and both
//     hands), and the least-squares slope of those medians on the strength;
//   over participants: the slopes tested against 0 with the exact sign-flip
//     test, so a participant counts once however many trials they did;
//   the smallest strength with a significant change: each strength against
//     the control (the participant-level p of participant_level.h), tested
//     in a fixed sequence from the strongest down at the study's alpha, and
//     stopped at the first that is not significant (Hsu & Berger 1999). The
//     family-wise error over the strengths stays at alpha without a Šidák
//     correction, as long as a stronger degradation does not change less.
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "analysis/study/study_analysis.h"

namespace hapticlab::analysis {

// The series of the study's "dose" block: the protocol text the study
// stored, and each analysed setting's stored parameters (name,
// settings_to_json text). Strengths whose setting has no trials are left
// out. Empty when the protocol has no "dose" (or when not one of its
// strengths was run). Throws DataError when a setting named like a strength
// holds another value of the field: the study's settings would not be what
// the protocol says.
std::optional<DoseSeries> find_dose_series(std::string_view protocol_json, const std::string& control,
                                           const std::vector<std::pair<std::string, std::string>>& settings_json);

// Every task x measure of `analysis`, which must hold its dose series and
// its participant_pairwise cells (run_statistics). Deterministic: the
// sign-flip test is exact up to 24 participants, seeded beyond.
std::vector<DoseResponseRow> dose_response(const StudyAnalysis& analysis);

}  // namespace hapticlab::analysis

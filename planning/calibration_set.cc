#include "planning/calibration_set.h"

namespace hapticlab::planning {

const std::vector<CalibrationSource>& calibration_sources() {
  static const std::vector<CalibrationSource> sources = {
      {"wagner2002",
       "Wagner CR, Stylopoulos N, Howe RD (2002). The role of force feedback in surgery: analysis of blunt "
       "dissection. Proc. 10th Symposium on Haptic Interfaces for Virtual Environment and Teleoperator Systems, "
       "68-74",
       "abstract (biorobotics.harvard.edu/pastprojects/ff_surgery.html); its figures and per-subject values "
       "could not be read here"},
      {"wagner2007",
       "Wagner CR, Stylopoulos N, Jackson PG, Howe RD (2007). The benefit of force feedback in surgery: "
       "examination of blunt dissection. Presence 16(3):252-262",
       "abstract (direct.mit.edu/pvar/article-abstract/16/3/252/18678); the full text (PDF) could not be read "
       "here"},
      {"thesis2004",
       "The source thesis (2004), chapter 3: Tables 3.3-3.6 (../shared/reference/thesis.txt)",
       "Tables 3.3, 3.4, 3.5 and 3.6, read in full"},
      {"bergholz2023",
       "Bergholz M, Ferle M, Weber BM (2023). The benefits of haptic feedback in robot assisted surgery and "
       "their moderators: a meta-analysis. Sci Rep 13:19215",
       "abstract (pmc.ncbi.nlm.nih.gov/articles/PMC10628231) and Table 2 (nature.com/articles/"
       "s41598-023-46641-8/tables/2); the peak-force and completion-time subgroup tables could not be read here"},
      {"golahmadi2021",
       "Golahmadi AK, Khan DZ, Mylonas GP, Marcus HJ (2021). Tool-tissue forces in surgery: a systematic "
       "review. Ann Med Surg 65:102268",
       "abstract (pmc.ncbi.nlm.nih.gov/articles/PMC8058906); no interval for the novice-expert difference is "
       "given there, and the per-study values could not be read here"},
  };
  return sources;
}

const std::vector<CalibrationTarget>& calibration_targets() {
  using Kind = CalibrationTarget::Kind;
  // Between-study spread of the mean-force effect: the weighted SD of the
  // seven task subgroups' g in Bergholz et al.'s Table 2 (catheter 1.72 of 5
  // observations, grasp 0.88 of 29, insertion 0.87 of 4, palpation 0.70 of
  // 7, section 0.16 of 9, suturing 0.96 of 3, tracing 0.83 of 4): 0.37.
  constexpr double kBetweenTaskSd = 0.37;
  static const std::vector<CalibrationTarget> targets = {
      {"wagner_mean_force", "wagner2007", "abstract (also wagner2002, abstract)",
       "the absence of force feedback increased the average force magnitude applied to the tissue by at least "
       "50 %",
       "a 20-participant within-subject study (Wagner 2007's size) of High Fidelity against No Force Feedback in "
       "the dissection, 3 trials each: the group's mean contact force of the dissecting tool (the cautery) under "
       "No Force Feedback is at least 1.5 times that under High Fidelity",
       Kind::kEvent, 1.5, 0.0, ""},
      {"wagner_peak_force", "wagner2007", "abstract (also wagner2002, abstract)",
       "and increased the peak force magnitude by at least 100 % (2002: by at least a factor of 2)",
       "the same study: the group's mean of the trials' largest contact force is at least 2 times higher",
       Kind::kEvent, 2.0, 0.0, ""},
      {"wagner_speed", "wagner2007", "abstract (also wagner2002, abstract)",
       "the rate ... of dissection [was] not significantly enhanced with force feedback",
       "the same study: a paired t test of the participants' log completion times (two-sided, 0.05) is not "
       "significant",
       Kind::kEvent, 0.0, 0.0, ""},
      {"thesis_nff_p95_dissection", "thesis2004", "Table 3.5",
       "No Force Feedback (3) against High Fidelity, 95p force: P = 8E-6 (significant)",
       "a simulated 3-surgeon study of Table 3.3's design analysed the thesis' way: the pairwise Friedman test of "
       "No Force Feedback in the dissection, 95th-percentile force, is significant at the Sidak level",
       Kind::kEvent, 0.0, 0.0, ""},
      {"thesis_nff_p95_clip", "thesis2004", "Table 3.6",
       "No Force Feedback (2) against High Fidelity, 95 per. force: P = 7E-6 (significant)",
       "the same, clip application task", Kind::kEvent, 0.0, 0.0, ""},
      {"thesis_nff_median_clip", "thesis2004", "Table 3.6",
       "No Force Feedback (2) against High Fidelity, 50 perc. force: P = 0.0071 (significant)",
       "the same, median force in the clip application task", Kind::kEvent, 0.0, 0.0, ""},
      {"thesis_nff_time_dissection", "thesis2004", "Table 3.5",
       "No Force Feedback (3), completion time: P = 0.25 (not significant)",
       "the same test on completion time in the dissection is not significant", Kind::kEvent, 0.0, 0.0, ""},
      {"thesis_nff_time_clip", "thesis2004", "Table 3.6",
       "No Force Feedback (2), completion time: P = 0.19 (not significant)",
       "the same test on completion time in the clip application task is not significant", Kind::kEvent, 0.0, 0.0,
       ""},
      {"thesis_others_p95", "thesis2004", "Tables 3.5 and 3.6",
       "every other setting against High Fidelity, 95p force: P >= 0.06 (none significant)",
       "no setting other than No Force Feedback differs significantly in the 95th-percentile force, in either "
       "task",
       Kind::kEvent, 0.0, 0.0, ""},
      {"thesis_surgeons_p95", "thesis2004", "Table 3.4",
       "intra-surgeon Friedman tests, 95p force: P = 0.006, 0.003, 0.01 (dissection), 6E-5, 0.002 (clip): all "
       "five significant",
       "each simulated surgeon's Friedman test across its settings (95th-percentile force, both hands as blocks) "
       "is significant at 0.05, all five",
       Kind::kEvent, 0.0, 0.0, ""},
      {"bergholz_mean_force", "bergholz2023", "abstract; Table 2 (Overall: 61 observations, 0.83 [0.66, 1.01])",
       "haptic feedback was effective in reducing average forces (Hedges' g = 0.83)",
       "read as the spread between studies, not as a laparoscopy figure: the model's effect of No Force Feedback "
       "on the dissecting tool's mean contact force, as a standardized difference of the participants' means "
       "(SD between participants, pooled over the two settings), is one study's effect among those pooled",
       Kind::kValue, 0.83, kBetweenTaskSd,
       "SD 0.37: the spread of Table 2's seven task subgroups (catheter 1.72 ... section 0.16), weighted by "
       "their observations"},
      {"bergholz_peak_force", "bergholz2023", "abstract",
       "and peak forces (Hedges' g = 0.69)",
       "the same for the trials' largest contact force", Kind::kValue, 0.69, kBetweenTaskSd,
       "the peak-force subgroup table could not be read here: the mean-force spread (0.37) is assumed"},
      {"bergholz_time", "bergholz2023", "abstract",
       "as well as reducing the completion time (Hedges' g = 0.83)",
       "the same for the completion time (No Force Feedback slower: g > 0)", Kind::kValue, 0.83, kBetweenTaskSd,
       "the completion-time subgroup table could not be read here: the mean-force spread (0.37) is assumed"},
      {"golahmadi_expertise", "golahmadi2021", "abstract",
       "novices exerted 22.7 % more force than experts (mean of average forces)",
       "the expertise trait: simulated novices' mean contact force over experts', High Fidelity, dissection",
       Kind::kValue, 1.227, 0.1,
       "no interval is published in the abstract: SD 0.1 is an assumption (a ratio known to about +-10 %)"},
  };
  return targets;
}

}  // namespace hapticlab::planning

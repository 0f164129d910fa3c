#pragma once
// Stage 3 of the study analysis: every statistics table (Tables 3.4-3.7,
// the whole-design tests, the KS bootstrap) as a function of the trials'
// measures in memory — from a database (analyze_study) or from simulated
// studies that were never stored (planning/).
#include "analysis/study/study_analysis.h"

namespace hapticlab::analysis {

// Runs the statistics on records already computed (analyze_study calls it;
// tests can feed hand-made records). Fills every table of `analysis`.
void run_statistics(StudyAnalysis& analysis);

}  // namespace hapticlab::analysis

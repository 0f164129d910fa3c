#pragma once
// Figures of the learning analysis (issue 38 §2), drawn by gnuplot
// (report/gnuplot.h) into a folder: curve_<k>.svg (participant k's trials
// with the AICc-chosen fit), group_medians.svg (each group's median over
// its participants at each trial index) and, with a CUSUM criterion,
// cusum_<k>.svg (the score with its limits h1 and -h0). Returns the file
// names written, plots.gp included.
#include <filesystem>
#include <string>
#include <vector>

#include "analysis/learning/learning_analysis.h"

namespace hapticlab::analysis::learning {

std::vector<std::string> write_learning_figures(const LearningAnalysis& analysis,
                                                const std::filesystem::path& dir,
                                                const std::filesystem::path& gnuplot);

}  // namespace hapticlab::analysis::learning

#pragma once
// Stage 4 of the study analysis: numbers and tables as text (p values as
// the thesis prints them, Tables 3.4-3.6 for a terminal). The HTML and
// Markdown report is analysis/report/.
#include <string>

#include "analysis/study/study_analysis.h"

namespace hapticlab::analysis {

// Short label for a setting in plots: initials of multi-word names
// ("No Force Feedback" -> "NFF", "Inertia + Backlash" -> "I+B"), numbers and
// "=" kept whole ("Insertion friction, dynamic_level_N = 0.45" ->
// "IFD=0.45"), else the name.
std::string setting_abbreviation(const std::string& name);

// The label of a task's pairwise table as the thesis numbers them: "Table
// 3.5" is the dissection's, "Table 3.6" the clip application's (whatever
// order the study lists its tasks in); another task's is "Table (TASK)".
std::string thesis_pairwise_table(const std::string& task);

// p-value as the thesis prints it: 2 significant digits, scientific below 1e-3.
std::string format_p(double p);

// A decision level as tables print it: 4 significant digits ("0.007301").
std::string format_level(double level);

// p printed next to its decision level: the thesis' form, with more
// significant digits when that would hide which side of the level p is on
// (0.00729 and 0.00734 against 0.007301 print as "0.00729" and "0.00734",
// not both "0.0073"). The printed value compares with format_level(level) as
// p compares with level.
std::string format_p(double p, double level);

// Tables 3.4–3.6 (plus the trial counts) as plain text for a terminal.
std::string format_headline_tables(const StudyAnalysis& analysis);

}  // namespace hapticlab::analysis

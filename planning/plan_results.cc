// Builds and writes a finished plan's tables and figures (plan_results.h).
#include "planning/plan_results.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "analysis/report/gnuplot.h"
#include "core/common/csv_format.h"
#include "core/common/output_file.h"
#include "planning/change_summary.h"
#include "planning/participant_reach.h"

namespace hapticlab::planning {
namespace {

namespace fs = std::filesystem;

void write_power_csv(const fs::path& path, const std::vector<PowerRow>& rows) {
  // Complete or absent, with the cause of a failure (output_file.h): a
  // fixed ".tmp" name, no check of the close and no fsync lost a table
  // silently before.
  write_file_atomically(path, power_csv_text(rows));
}

// One task's figure data: a gnuplot block per setting (pairwise rows of
// `measure`), in the order the settings first appear; empty when none.
std::vector<std::string> figure_settings(const std::vector<PowerRow>& rows, const std::string& task,
                                         const std::string& measure, std::ostringstream& data) {
  std::vector<std::string> settings;
  for (const auto& r : rows)
    if (r.method == "pairwise" && r.task == task && r.measure == measure &&
        std::find(settings.begin(), settings.end(), r.setting) == settings.end())
      settings.push_back(r.setting);
  for (const std::string& s : settings) {
    for (const auto& r : rows)
      if (r.method == "pairwise" && r.task == task && r.measure == measure && r.setting == s)
        data << r.participants << ' ' << 100.0 * r.rate << ' ' << 100.0 * r.wilson_low << ' '
             << 100.0 * r.wilson_high << '\n';
    data << "\n\n";
  }
  return settings;
}

// One figure per task: power against the number of participants, one line
// per setting, with Wilson 95 % intervals as error bars.
std::vector<std::string> draw_power(const fs::path& out, const std::vector<PowerRow>& rows,
                                    const std::string& measure) {
  analysis::GnuplotScript script;
  std::vector<std::string> tasks;
  for (const auto& r : rows)
    if (std::find(tasks.begin(), tasks.end(), r.task) == tasks.end()) tasks.push_back(r.task);
  for (const std::string& task : tasks) {
    std::ostringstream data;
    const std::vector<std::string> settings = figure_settings(rows, task, measure, data);
    if (settings.empty()) continue;
    std::string block = "power_";
    for (char c : task) block += std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
    script.add_datablock(block, data.str());
    std::string plot = "set title " + analysis::gnuplot_quote(task + ": " + measure + ", each setting against the control") +
                       "\nset xlabel 'participants'\nset ylabel 'studies significant [%]'\nset yrange [0:100]\n"
                       "set key outside right\nset grid\nplot ";
    for (std::size_t i = 0; i < settings.size(); ++i) {
      plot += (i ? ", " : "") + std::string("$") + block + " index " + std::to_string(i) +
              " using 1:2:3:4 with yerrorlines lw 2 title " + analysis::gnuplot_quote(settings[i]);
    }
    script.add_plot(block + ".svg", plot, 900, 500);
  }
  if (script.outputs().empty()) return {};
  analysis::run_gnuplot(script, out, analysis::find_gnuplot());
  return script.outputs();
}

// One note per participant count whose participant-level power is 0
// whatever the data (participant_reach.h); the level is the simulated
// studies' own: alpha over every setting but the control.
std::vector<std::string> participant_power_notes(const protocols::Protocol& protocol, const PlanInputs& inputs,
                                                 const std::vector<PowerRow>& rows) {
  std::vector<std::string> notes;
  const std::size_t comparisons = protocol.settings.empty() ? 0 : protocol.settings.size() - 1;
  for (int n : inputs.participants) {
    const bool shown = std::any_of(rows.begin(), rows.end(), [&](const PowerRow& r) {
      return r.method == "participant_pairwise" && r.participants == n;
    });
    if (!shown) continue;
    if (std::string note = participant_power_note(n, inputs.alpha, comparisons); !note.empty())
      notes.push_back(std::move(note));
  }
  return notes;
}

}  // namespace

std::string power_csv_text(const std::vector<PowerRow>& rows) {
  std::ostringstream out;
  // tests: studies (pairwise) or participants' Table 3.4 tests (participant).
  // wilson_*: the simulation's sampling only; model_*: with the fitted
  // population's uncertainty (empty without it).
  out << "participants,method,task,setting,measure,tests,significant,rate,wilson_low,wilson_high,model_low,"
         "model_high\n";
  for (const auto& r : rows) {
    out << r.participants << ',' << r.method << ',' << csv_text(r.task) << ',' << csv_text(r.setting) << ','
        << r.measure << ',' << r.tests << ',' << r.significant << ',' << format_number(r.rate) << ','
        << format_number(r.wilson_low) << ',' << format_number(r.wilson_high) << ','
        << (std::isfinite(r.model_low) ? format_number(r.model_low) : "") << ','
        << (std::isfinite(r.model_high) ? format_number(r.model_high) : "") << '\n';
  }
  return out.str();
}

PlanResults write_plan_results(const protocols::Protocol& protocol, const PlanInputs& inputs,
                               const PlanDesign& design, const std::vector<StudyOutcome>& outcomes,
                               const fs::path& out, const std::string& measure, bool plots) {
  std::vector<std::string> setting_order;
  for (const auto& s : protocol.settings) setting_order.push_back(s.settings.name);
  const bool model_uncertainty = inputs.model_uncertainty;
  PlanResults r;
  r.folder = out;
  r.rows = summarize_power(outcomes, setting_order, model_uncertainty ? kDrawGroups : 1);
  r.false_positives = false_positive_rates(outcomes, design.null_settings);
  r.staircases = summarize_staircases(outcomes);
  r.power_csv = out / "power.csv";
  write_power_csv(r.power_csv, r.rows);
  // Each setting's predicted change against the control beside the power
  // to detect it (issue 35 §4). One variant, named by how the studies drew
  // their populations: the fit's point estimate, or a posterior draw per
  // group of studies (then the power cells carry the model interval).
  r.variants = {{model_uncertainty ? "with model uncertainty" : "model fixed",
                 summarize_changes(outcomes, setting_order), r.rows, summarize_timeouts(outcomes, setting_order)}};
  ComparisonReportOptions report;
  report.control = design.control;
  report.participants = inputs.participants;
  report.settings = setting_order;
  r.comparison = comparison_markdown(r.variants, report);
  r.notes = participant_power_notes(protocol, inputs, r.rows);
  std::string notes_md;
  for (const std::string& note : r.notes) notes_md += "\nNote: " + note + ".\n";
  r.change_csv = out / "predicted_change.csv";
  r.comparison_md = out / "comparison.md";
  write_file_atomically(r.change_csv, comparison_csv(r.variants, report));
  write_file_atomically(r.comparison_md,
                        "# " + protocol.study + ": predicted change and power\n\n" + r.comparison + notes_md);
  if (plots) r.figures = draw_power(out, r.rows, measure);
  return r;
}

}  // namespace hapticlab::planning

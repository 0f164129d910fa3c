// Prints a finished plan's tables or their JSON (plan_results_print.h).
#include "app/plan/plan_results_print.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <set>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

namespace hapticlab::app {
namespace {

nlohmann::json plan_number_or_null(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); }

nlohmann::json power_rows_json(const std::vector<planning::PowerRow>& rows) {
  nlohmann::json list = nlohmann::json::array();
  for (const auto& r : rows) {
    list.push_back({{"participants", r.participants}, {"method", r.method}, {"task", r.task},
                    {"setting", r.setting}, {"measure", r.measure}, {"significant", r.significant},
                    {"tests", r.tests}, {"rate", r.rate}, {"wilson_low", r.wilson_low},
                    {"wilson_high", r.wilson_high}, {"model_low", plan_number_or_null(r.model_low)},
                    {"model_high", plan_number_or_null(r.model_high)}});
  }
  return list;
}

nlohmann::json false_positives_json(const std::vector<planning::FalsePositiveRow>& fp) {
  nlohmann::json fps = nlohmann::json::array();
  for (const auto& r : fp)
    fps.push_back({{"participants", r.participants}, {"method", r.method}, {"measure", r.measure},
                   {"studies", r.studies}, {"with_false_positive", r.with_false_positive}, {"rate", r.rate},
                   {"wilson_low", r.wilson_low}, {"wilson_high", r.wilson_high}});
  return fps;
}

nlohmann::json staircases_json(const std::vector<planning::StaircaseSummaryRow>& stairs) {
  nlohmann::json st = nlohmann::json::array();
  for (const auto& r : stairs)
    st.push_back({{"participants", r.participants}, {"studies", r.studies}, {"staircases", r.staircases},
                  {"with_threshold", r.with_threshold}, {"rate", r.rate}, {"wilson_low", r.wilson_low},
                  {"wilson_high", r.wilson_high}, {"mean_threshold", plan_number_or_null(r.mean_threshold)},
                  {"sd_between_participants", plan_number_or_null(r.sd_between_participants)},
                  {"sd_of_study_means", plan_number_or_null(r.sd_of_study_means)}, {"mean_trials", r.mean_trials}});
  return st;
}

nlohmann::json changes_json(const planning::ReportVariant& v) {
  nlohmann::json ch = nlohmann::json::array();
  for (const planning::ChangeRow& r : v.changes)
    ch.push_back({{"variant", v.label}, {"participants", r.participants}, {"task", r.task},
                  {"setting", r.setting}, {"measure", r.measure}, {"studies", r.studies}, {"median", r.median},
                  {"low", r.low}, {"high", r.high}});
  return ch;
}

nlohmann::json timeouts_json(const planning::ReportVariant& v) {
  nlohmann::json out = nlohmann::json::array();
  for (const planning::TimeoutRow& r : v.timeouts)
    out.push_back({{"variant", v.label}, {"participants", r.participants}, {"task", r.task},
                   {"setting", r.setting}, {"trials", r.trials}, {"timed_out", r.timed_out}, {"rate", r.rate},
                   {"wilson_low", r.wilson_low}, {"wilson_high", r.wilson_high}});
  return out;
}

void print_plan_json(const planning::PlanInputs& inputs, const planning::PlanDesign& design,
                     const planning::PlanResults& r, const PlanRunSummary& run) {
  nlohmann::json j;
  j["studies_per_count"] = inputs.studies;
  j["participants"] = inputs.participants;
  j["seconds_this_run"] = run.seconds_this_run;
  j["studies_this_run"] = run.studies_this_run;
  j["csv"] = r.power_csv.string();
  j["figures"] = r.figures;
  j["population"] = run.population;
  j["model_uncertainty"] = inputs.model_uncertainty;
  j["rows"] = power_rows_json(r.rows);
  j["notes"] = r.notes;
  j["null_settings"] = design.null_settings;
  j["family_wise_false_positives"] = false_positives_json(r.false_positives);
  j["staircase"] = staircases_json(r.staircases);
  j["predicted_change"] = changes_json(r.variants.front());
  j["timed_out"] = timeouts_json(r.variants.front());
  j["comparison"] = {{"csv", r.change_csv.string()}, {"markdown", r.comparison_md.string()}};
  std::printf("%s\n", j.dump(2).c_str());
}

// What one table prints: its rows, each row's label and the cells per count.
struct PowerTableView {
  const std::vector<planning::PowerRow>& rows;
  const std::vector<int>& counts;
  const std::set<std::string>& null_settings;
  const std::string& measure;
  bool model_uncertainty;
};

void print_power_cell(const PowerTableView& v, const std::string& method, const std::string& task,
                      const std::string& setting, int n, int width) {
  const auto it = std::find_if(v.rows.begin(), v.rows.end(), [&](const planning::PowerRow& r) {
    return r.method == method && r.measure == v.measure && r.task == task && r.setting == setting &&
           r.participants == n;
  });
  char cell[96] = "";
  if (it != v.rows.end() && std::isfinite(it->model_low))
    std::snprintf(cell, sizeof cell, "%3.0f%% [%2.0f,%3.0f] model [%2.0f,%3.0f]", 100 * it->rate,
                  100 * it->wilson_low, 100 * it->wilson_high, 100 * it->model_low, 100 * it->model_high);
  else if (it != v.rows.end())
    std::snprintf(cell, sizeof cell, "%3.0f%% [%2.0f,%3.0f]", 100 * it->rate, 100 * it->wilson_low,
                  100 * it->wilson_high);
  std::printf("  %*s", width, cell);
}

void print_power_table(const PowerTableView& v, const std::string& method, const char* title) {
  // A staircase protocol's baseline alone has nothing to compare.
  if (std::none_of(v.rows.begin(), v.rows.end(), [&](const planning::PowerRow& r) { return r.method == method; }))
    return;
  std::printf("\n%s, %s: share of simulated studies in which the setting differs significantly from the "
              "control (Šidák level), Wilson 95 %% interval (simulation only)%s\n", title, v.measure.c_str(),
              v.model_uncertainty ? " and, after 'model', the 95 % interval with the model's uncertainty" : "");
  const int width = v.model_uncertainty ? 32 : 16;
  std::printf("%-12s %-32s", "task", "setting");
  for (int n : v.counts) std::printf("  %*s", width, (std::to_string(n) + " participants").c_str());
  std::printf("\n");
  std::vector<std::pair<std::string, std::string>> lines;
  for (const auto& r : v.rows)
    if (r.method == method && r.measure == v.measure &&
        std::find(lines.begin(), lines.end(), std::make_pair(r.task, r.setting)) == lines.end())
      lines.push_back({r.task, r.setting});
  for (const auto& [task, setting] : lines) {
    const std::string label = setting + (v.null_settings.count(setting) ? " (null)" : "");
    std::printf("%-12s %-32s", task.c_str(), label.c_str());
    for (int n : v.counts) print_power_cell(v, method, task, setting, n, width);
    std::printf("\n");
  }
}

void print_false_positives(const std::vector<planning::FalsePositiveRow>& fp, const std::string& measure) {
  if (fp.empty()) return;
  const planning::SimulatedStudyOptions sim;
  std::printf("\nFamily-wise false positives: share of studies in which any comparison of a null setting "
              "(a copy of the control) came out significant, %s\n", measure.c_str());
  for (const auto& r : fp)
    if (r.measure == measure)
      std::printf("  %-22s %3d participants: %5.1f%% [%4.1f, %5.1f] of %d studies (nominal %g%%)\n",
                  r.method.c_str(), r.participants, 100 * r.rate, 100 * r.wilson_low, 100 * r.wilson_high,
                  r.studies, 100 * sim.analysis.alpha);
}

void print_staircases(const protocols::Protocol& protocol, const std::vector<planning::StaircaseSummaryRow>& stairs) {
  if (!protocol.staircase) return;
  const auto& sp = protocol.staircase->spec;
  std::printf("\nStaircase of %s (%s changed by %g %% from %s): thresholds found, their mean and spread\n",
              sp.field.c_str(), sp.measure.c_str(), 100 * sp.change, sp.baseline.c_str());
  for (const auto& r : stairs)
    std::printf("  %3d participants: %5.1f%% [%4.1f, %5.1f] of %d staircases ended with a threshold; mean %.3g, "
                "SD %.3g between participants, SD %.3g of a study's mean; %.1f trials each\n",
                r.participants, 100 * r.rate, 100 * r.wilson_low, 100 * r.wilson_high, r.staircases,
                r.mean_threshold, r.sd_between_participants, r.sd_of_study_means, r.mean_trials);
}

void print_participant_level(const std::vector<planning::PowerRow>& rows, const std::string& measure) {
  if (std::any_of(rows.begin(), rows.end(), [](const planning::PowerRow& r) { return r.method == "participant"; }))
    std::printf("\nParticipant-level Friedman (Table 3.4) on %s: share of participants' tests significant\n",
                measure.c_str());
  for (const auto& r : rows)
    if (r.method == "participant" && r.measure == measure)
      std::printf("  %-12s %3d participants: %5.1f%% [%4.1f, %5.1f] of %d tests\n", r.task.c_str(), r.participants,
                  100 * r.rate, 100 * r.wilson_low, 100 * r.wilson_high, r.tests);
}

}  // namespace

void print_plan_results(const protocols::Protocol& protocol, const planning::PlanInputs& inputs,
                        const planning::PlanDesign& design, const planning::PlanResults& results,
                        const std::string& measure, bool json, const PlanRunSummary& run) {
  if (json) return print_plan_json(inputs, design, results, run);
  std::printf("\n%s\n", run.did.c_str());
  const PowerTableView view{results.rows, inputs.participants, design.null_settings, measure,
                            inputs.model_uncertainty};
  print_power_table(view, "pairwise", "Thesis procedure (pairwise Friedman, repetitions and hands as replicates)");
  print_power_table(view, "participant_pairwise", "Participant level (one value per participant, sign-flip test)");
  for (const std::string& note : results.notes) std::printf("note: %s\n", note.c_str());
  print_false_positives(results.false_positives, measure);
  print_staircases(protocol, results.staircases);
  print_participant_level(results.rows, measure);
  if (!results.variants.front().changes.empty())
    std::printf("\nPredicted change against %s and the power to detect it, every measure (%s):\n%s",
                design.control.c_str(), results.comparison_md.c_str(), results.comparison.c_str());
  std::printf("\nAll measures: %s, %s", results.power_csv.c_str(), results.change_csv.c_str());
  for (const auto& f : results.figures) std::printf(", %s", (results.folder / f).c_str());
  std::printf("\n");
}

}  // namespace hapticlab::app

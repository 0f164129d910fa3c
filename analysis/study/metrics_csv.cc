#include "analysis/study/metrics_csv.h"

#include <cmath>
#include <ostream>
#include <string>

#include "analysis/stats/data_error.h"
#include "core/common/csv_format.h"
#include "core/common/output_file.h"

namespace hapticlab::analysis {
namespace {

// Shortest round-trip form; a missing measure (NaN) is an empty field.
std::string number(double v) { return std::isfinite(v) ? format_number(v) : std::string(); }

constexpr const char* kAxisNames[3] = {"insertion", "pitch", "yaw"};

std::string energy_header() {
  std::string h;
  for (const char* axis : kAxisNames) h += std::string("device_out_") + axis + "_J,device_in_" + axis + "_J,";
  return h + "engine_out_J,engine_in_J,";
}

// The energy columns of one hand: empty when the trial's energy was not read.
std::string energy_fields(const std::optional<HandEnergy>& e) {
  if (!e) return ",,,,,,,,";
  std::string f;
  for (const AxisEnergy& d : e->device) f += number(d.out_J) + ',' + number(d.in_J) + ',';
  return f + number(e->engine_out_J()) + ',' + number(e->engine_in_J()) + ',';
}

}  // namespace

void write_metrics_csv(const StudyAnalysis& a, std::ostream& out) {
  // `site` only for a merged multi-site study: a one-site file's CSV keeps
  // its columns.
  const bool sites = !a.participant_sites.empty();
  out << "trial_id,participant," << (sites ? "site," : "") << "task,setting,repetition,block,trial_number,status,instrument,task_start_s,task_end_s,"
         "completion_time_s,samples,force_samples,force_median_N,force_p95_N,speed_median_m_per_s,path_length_m,"
      << energy_header() << "note\n";
  for (const TrialRecord& t : a.trials) {
    for (int hand = 0; hand < 2; ++hand) {
      const HandMetrics& h = t.hands[static_cast<std::size_t>(hand)];
      const bool have = t.window.has_value();
      std::string note = t.problem.empty() ? t.note : t.problem;
      if (have && h.samples == 0)
        // A window between the task's events holds samples of any real trial:
        // none means its events and samples disagree (an edited or damaged
        // file), not a light touch.
        note = "the task window holds none of the trial's samples: its events and samples disagree; measures "
               "missing, the completion time is the events' alone";
      else if (have && h.force_samples == 0)
        note = "no sample reached the contact threshold: force measures missing";
      out << t.trial_id << ',' << csv_text(t.participant) << ',';
      if (sites) {
        const auto it = a.participant_sites.find(t.participant);
        out << csv_text(it == a.participant_sites.end() ? std::string() : it->second) << ',';
      }
      out << csv_text(t.task) << ',' << csv_text(t.setting) << ','
          << t.repetition << ',' << t.block << ',' << t.position << ',' << t.status << ',' << hand << ','
          << (have ? number(t.window->start_s) : "") << ',' << (have ? number(t.window->end_s) : "") << ','
          << number(t.value(Measure::kCompletionTime, hand)) << ',' << (have ? std::to_string(h.samples) : "")
          << ',' << (have ? std::to_string(h.force_samples) : "") << ',' << number(t.value(Measure::kForceMedian, hand))
          << ',' << number(t.value(Measure::kForceP95, hand)) << ',' << number(t.value(Measure::kSpeedMedian, hand))
          << ',' << number(t.value(Measure::kPathLength, hand)) << ','
          << energy_fields(t.energy[static_cast<std::size_t>(hand)]) << csv_text(note) << '\n';
    }
  }
}

void write_metrics_csv(const StudyAnalysis& a, const std::filesystem::path& path) {
  try {
    AtomicOutputFile file(path);
    write_metrics_csv(a, file.stream());
    file.commit();
  } catch (const OutputFileError& e) {
    throw DataError(std::string("cannot write the metrics CSV: ") + e.what());
  }
}

}  // namespace hapticlab::analysis

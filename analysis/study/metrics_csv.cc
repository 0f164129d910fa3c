#include "analysis/study/metrics_csv.h"

#include <cmath>
#include <cstdio>
#include <ostream>
#include <string>

#include "analysis/stats/data_error.h"
#include "core/io/output_file.h"

namespace hapticlab::analysis {
namespace {

std::string number(double v) {
  if (!std::isfinite(v)) return "";
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

// RFC 4180 quoting, only where needed (names may hold commas).
std::string field(const std::string& s) {
  if (s.find_first_of(",\"\n\r") == std::string::npos) return s;
  std::string out = "\"";
  for (char c : s) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + '"';
}

}  // namespace

void write_metrics_csv(const StudyAnalysis& a, std::ostream& out) {
  out << "trial_id,participant,task,setting,repetition,block,trial_number,status,hand,task_start_s,task_end_s,"
         "completion_time_s,samples,force_samples,force_median_N,force_p95_N,speed_median_m_per_s,path_length_m,"
         "note\n";
  for (const TrialRecord& t : a.trials) {
    for (int hand = 0; hand < 2; ++hand) {
      const HandMetrics& h = t.hands[static_cast<std::size_t>(hand)];
      const bool have = t.window.has_value();
      std::string note = t.problem;
      if (have && h.force_samples == 0) note = "no sample reached the contact threshold: force measures missing";
      out << t.trial_id << ',' << field(t.participant) << ',' << field(t.task) << ',' << field(t.setting) << ','
          << t.repetition << ',' << t.block << ',' << t.position << ',' << t.status << ',' << hand_name(hand) << ','
          << (have ? number(t.window->start_s) : "") << ',' << (have ? number(t.window->end_s) : "") << ','
          << number(t.value(Measure::kCompletionTime, hand)) << ',' << (have ? std::to_string(h.samples) : "")
          << ',' << (have ? std::to_string(h.force_samples) : "") << ',' << number(t.value(Measure::kForceMedian, hand))
          << ',' << number(t.value(Measure::kForceP95, hand)) << ',' << number(t.value(Measure::kSpeedMedian, hand))
          << ',' << number(t.value(Measure::kPathLength, hand)) << ',' << field(note) << '\n';
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

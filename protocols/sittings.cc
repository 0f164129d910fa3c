#include "protocols/sittings.h"

#include <cmath>
#include <ctime>

#include "core/common/csv_format.h"

namespace hapticlab::protocols {

std::vector<Sitting> group_sittings(const Protocol& p, std::size_t group) {
  const TransferDesign& d = p.transfer.value();
  const Group& g = d.groups.at(group);
  std::vector<Sitting> out;
  for (const Phase& ph : d.phases) {
    const bool training = ph.kind == PhaseKind::kTraining;
    if (training && !g.training_setting) continue;  // a control group only does the tests
    for (int s = 1; s <= ph.sessions; ++s)
      out.push_back({ph.kind, s, training ? *g.training_setting : ph.setting, ph.trials, ph.min_gap_h});
  }
  return out;
}

SittingDue next_sitting_due(const std::vector<Sitting>& sittings, std::size_t done,
                            std::optional<double> last_end_unix_s) {
  SittingDue due;
  due.next = std::min(done, sittings.size());
  if (due.next == 0 || due.next == sittings.size() || !last_end_unix_s) return due;
  due.due_unix_s = *last_end_unix_s + sittings[due.next].min_gap_h * 3600.0;
  return due;
}

std::string utc_text(double unix_s) {
  const auto t = static_cast<std::time_t>(std::floor(unix_s));
  std::tm utc{};
  gmtime_r(&t, &utc);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &utc);
  return text;
}

SittingStart check_sitting_start(const std::string& participant, const std::vector<Sitting>& sittings,
                                 const SittingDue& due, double now_unix_s, bool override_early) {
  if (due.next >= sittings.size())
    throw std::invalid_argument("participant " + participant + " has done every sitting of the protocol");
  if (!due.due_unix_s || now_unix_s >= *due.due_unix_s) return SittingStart::kDue;
  if (override_early) return SittingStart::kOverridden;
  const Sitting& s = sittings[due.next];
  const double wait_h = (*due.due_unix_s - now_unix_s) / 3600.0;
  throw SittingTooEarly("participant " + participant + "'s next sitting (" + std::string(phase_kind_name(s.phase)) +
                        " session " + std::to_string(s.session) + ") is not due before " + utc_text(*due.due_unix_s) +
                        " (" + format_number(std::round(wait_h * 10.0) / 10.0) + " h from now; the protocol's minimum gap is " +
                        format_number(s.min_gap_h) + " h): refused; the operator may override with " + kOverrideDueFlag +
                        ", which is logged");
}

}  // namespace hapticlab::protocols

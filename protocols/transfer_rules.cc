#include "protocols/transfer_rules.h"

#include <set>

#include "core/common/csv_format.h"
#include "protocols/group_assignment.h"
#include "protocols/protocol_error.h"

namespace hapticlab::protocols {
namespace {

std::string quoted(const std::string& s) { return "\"" + s + "\""; }

void check_setting(const Protocol& p, const std::string& name, const std::string& path, const std::string& source) {
  if (!p.find_setting(name))
    throw ProtocolError(source, path, "is " + quoted(name) + ", but is not one of the settings");
}

void check_groups(const Protocol& p, const TransferDesign& d, const std::string& source) {
  if (d.groups.empty()) throw ProtocolError(source, "groups", "is empty, but must list at least one group");
  std::set<std::string> names;
  bool any_size = false;
  int size_sum = 0;
  for (std::size_t i = 0; i < d.groups.size(); ++i) {
    const Group& g = d.groups[i];
    const std::string path = index_path("groups", i);
    if (g.name.empty() || g.name.size() > kMaxGroupNameLength)
      throw ProtocolError(source, path + ".name",
                          "is " + quoted(g.name) + ", but must be 1.." + std::to_string(kMaxGroupNameLength) + " bytes");
    if (!names.insert(g.name).second)
      throw ProtocolError(source, path + ".name", "is " + quoted(g.name) + ", which is already used; group names must be unique");
    if (g.training_setting) check_setting(p, *g.training_setting, path + ".training", source);
    if (g.size) {
      if (*g.size < 1)
        throw ProtocolError(source, path + ".size",
                            "is " + std::to_string(*g.size) + ", but a group must have at least 1 participant (group " +
                                quoted(g.name) + " would have none)");
      any_size = true;
      size_sum += *g.size;
    }
  }
  if (!any_size) return;
  for (std::size_t i = 0; i < d.groups.size(); ++i)
    if (!d.groups[i].size)
      throw ProtocolError(source, index_path("groups", i) + ".size",
                          "is missing, but other groups declare their size: declare every group's or none");
  if (size_sum != static_cast<int>(p.participants.size()))
    throw ProtocolError(source, "groups", "declare sizes summing to " + std::to_string(size_sum) + ", but there are " +
                                              std::to_string(p.participants.size()) + " participants");
}

void check_phases(const Protocol& p, const TransferDesign& d, const std::string& source) {
  static const char* const kOrder = "pre_test (optional), training, post_test, retention (optional)";
  int previous = -1;
  for (std::size_t i = 0; i < d.phases.size(); ++i) {
    const Phase& ph = d.phases[i];
    const std::string path = index_path("phases", i);
    const std::string name(phase_kind_name(ph.kind));
    const int rank = static_cast<int>(ph.kind);
    if (rank == previous)
      throw ProtocolError(source, path + ".phase", "is " + quoted(name) + ", which is already given; each phase is given once");
    if (rank < previous) {
      const std::string earlier(phase_kind_name(static_cast<PhaseKind>(previous)));
      const bool test_before_training = ph.kind == PhaseKind::kTraining;
      throw ProtocolError(source, path + ".phase",
                          "is " + quoted(name) + ", but comes after " + quoted(earlier) +
                              (test_before_training ? ": a " + earlier + " tests what training taught, so it must come "
                                                      "after training"
                                                    : "") +
                              "; phases go in the order " + kOrder);
    }
    previous = rank;
    const bool training = ph.kind == PhaseKind::kTraining;
    if (training && !ph.setting.empty())
      throw ProtocolError(source, path + ".setting",
                          "is " + quoted(ph.setting) + ", but the training phase has no setting: each group trains on its "
                          "own (groups[i].training)");
    if (!training) {
      if (ph.setting.empty())
        throw ProtocolError(source, path + ".setting", "is missing, but a test names the setting every group is tested on");
      check_setting(p, ph.setting, path + ".setting", source);
    }
    const int max_sessions = training ? kMaxTrainingSessions : 1;
    if (ph.sessions < 1 || ph.sessions > max_sessions)
      throw ProtocolError(source, path + ".sessions",
                          "is " + std::to_string(ph.sessions) + ", but must be >= 1 and <= " + std::to_string(max_sessions) +
                              (training ? "" : " (a test is one sitting)"));
    if (!(ph.min_gap_h >= 0.0) || !(ph.min_gap_h <= kMaxMinGap_h))
      throw ProtocolError(source, path + ".min_gap_h",
                          "is " + format_number(ph.min_gap_h) + ", but must be >= 0 and <= " + format_number(kMaxMinGap_h));
    for (const Task& t : p.tasks) {
      const std::string task(task_name(t));
      const auto it = ph.trials.find(task);
      const int n = it == ph.trials.end() ? 0 : it->second;
      if (n < 1 || n > kMaxPhaseTrials)
        throw ProtocolError(source, path + ".trials." + task,
                            (it == ph.trials.end() ? std::string("is missing") : "is " + std::to_string(n)) +
                                ", but must be >= 1 and <= " + std::to_string(kMaxPhaseTrials) +
                                " (trials per sitting of every task)");
    }
    for (const auto& [task, n] : ph.trials)
      if (!task_from_name(task) && p.ve == Ve::kSimulated)
        throw ProtocolError(source, path + ".trials." + task, "is given, but " + quoted(task) + " is not one of the tasks");
  }
  if (!d.find_phase(PhaseKind::kTraining))
    throw ProtocolError(source, "phases", std::string("has no training phase; phases go in the order ") + kOrder);
  if (!d.find_phase(PhaseKind::kPostTest))
    throw ProtocolError(source, "phases", std::string("has no post_test; phases go in the order ") + kOrder);
  if (const Phase* r = d.find_phase(PhaseKind::kRetention)) {
    const double span_h = training_span_h(d);
    if (!(r->min_gap_h > span_h)) {
      std::size_t i = 0;
      while (d.phases[i].kind != PhaseKind::kRetention) ++i;
      throw ProtocolError(source, index_path("phases", i) + ".min_gap_h",
                          "(the retention delay) is " + format_number(r->min_gap_h) +
                              " h, but must exceed the training span, " + format_number(span_h) +
                              " h ((training.sessions - 1) x training.min_gap_h): retention measures what is kept after "
                              "a delay longer than the training took");
    }
  }
}

void check_attributes(const Protocol& p, const TransferDesign& d, const std::string& source) {
  if (d.stratify_by.empty()) return;
  for (std::size_t i = 0; i < p.participants.size(); ++i) {
    const ParticipantSpec& ps = p.participants[i];
    const auto it = ps.attributes.find(d.stratify_by);
    if (it == ps.attributes.end() || it->second.empty())
      throw ProtocolError(source, index_path("participants", i) + ".attributes." + d.stratify_by,
                          "is missing for participant " + quoted(ps.code) + ", but stratify_by names " +
                              quoted(d.stratify_by) + ": every participant needs it to be randomized");
  }
}

}  // namespace

double training_span_h(const TransferDesign& design) {
  const Phase* t = design.find_phase(PhaseKind::kTraining);
  return t == nullptr ? 0.0 : (t->sessions - 1) * t->min_gap_h;
}

void validate_transfer_design(const Protocol& p, const std::string& source) {
  const TransferDesign& d = *p.transfer;
  check_groups(p, d, source);
  check_phases(p, d, source);
  check_attributes(p, d, source);
  assign_groups(p, source);  // refuses a group left without participants
}

}  // namespace hapticlab::protocols

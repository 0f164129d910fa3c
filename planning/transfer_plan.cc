#include "planning/transfer_plan.h"

#include <stdexcept>

namespace hapticlab::planning {
namespace {

const EngineSettings& settings_named(const protocols::Protocol& p, const std::string& name, const std::string& where) {
  const auto index = p.find_setting(name);
  if (!index) throw std::invalid_argument(where + ": setting '" + name + "' is not among the protocol's settings");
  return p.settings[*index].settings.engine;
}

}  // namespace

std::vector<TransferDesign> transfer_designs(const protocols::Protocol& protocol) {
  using protocols::PhaseKind;
  if (!protocol.transfer)
    throw std::invalid_argument("protocol: it has no groups; plan power simulates its within-participant design");
  const protocols::TransferDesign& t = *protocol.transfer;
  const protocols::Phase* pre = t.find_phase(PhaseKind::kPreTest);
  const protocols::Phase* training = t.find_phase(PhaseKind::kTraining);
  const protocols::Phase* post = t.find_phase(PhaseKind::kPostTest);
  const protocols::Phase* retention = t.find_phase(PhaseKind::kRetention);
  if (post == nullptr || training == nullptr)
    throw std::invalid_argument("phases: a training and a post_test phase are required");
  for (const protocols::Phase* test : {pre, retention}) {
    if (test != nullptr && test->setting != post->setting)
      throw std::invalid_argument("phases." + std::string(protocols::phase_kind_name(test->kind)) + ".setting is '" +
                                  test->setting + "', but plan power simulates every test on one setting (post_test's '" +
                                  post->setting + "')");
  }
  if (protocol.participants.empty()) throw std::invalid_argument("participants: none");
  const int familiarization = protocol.participants.front().training_trials;
  for (const protocols::ParticipantSpec& ps : protocol.participants) {
    if (ps.training_trials != familiarization)
      throw std::invalid_argument("participants: training_trials differ (" + ps.code + " has " +
                                  std::to_string(ps.training_trials) + ", " + protocol.participants.front().code +
                                  " " + std::to_string(familiarization) +
                                  "); plan power simulates one familiarization for everybody");
  }
  const EngineSettings& test_settings = settings_named(protocol, post->setting, "phases.post_test");
  std::vector<TransferDesign> out;
  for (const protocols::Task& task : protocol.tasks) {
    const std::string name(protocols::task_name(task));
    auto trials_of = [&](const protocols::Phase* phase) {
      if (phase == nullptr) return 0;
      const auto it = phase->trials.find(name);
      return it == phase->trials.end() ? 0 : it->second;
    };
    TransferDesign d;
    d.task = name;
    d.test_settings = test_settings;
    d.familiarization_trials = familiarization;
    d.pre_trials = trials_of(pre);
    d.post_trials = trials_of(post);
    d.retention_trials = trials_of(retention);
    for (const protocols::Group& g : t.groups) {
      TransferGroup group;
      group.name = g.name;
      if (g.training_setting) {
        group.training.push_back({settings_named(protocol, *g.training_setting, "groups." + g.name + ".training"),
                                  training->sessions * trials_of(training)});
      }
      d.groups.push_back(std::move(group));
    }
    out.push_back(std::move(d));
  }
  return out;
}

}  // namespace hapticlab::planning

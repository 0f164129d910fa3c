#include "planning/plan_inputs.h"

#include <algorithm>
#include <charconv>
#include <stdexcept>

#include "analysis/stats/percentile.h"
#include "core/common/build_info.h"
#include "core/common/csv_format.h"
#include "core/common/output_file.h"
#include "core/common/sha256.h"
#include "core/settings/settings_json.h"

namespace hapticlab::planning {
namespace {

using nlohmann::json;

PlanSetting plan_setting_of(const protocols::ProtocolSetting& s) {
  return {s.settings.name, s.source, sha256_hex(settings_to_json(s.settings).dump())};
}

json plan_settings_json(const std::vector<PlanSetting>& list) {
  json out = json::array();
  for (const PlanSetting& s : list) out.push_back({{"name", s.name}, {"source", s.source}, {"sha256", s.sha256}});
  return out;
}

std::vector<PlanSetting> plan_settings_from(const json& list) {
  std::vector<PlanSetting> out;
  for (const json& s : list)
    out.push_back({s.at("name").get<std::string>(), s.at("source").get<std::string>(), s.at("sha256").get<std::string>()});
  return out;
}

std::string joined_counts(const std::vector<int>& v) {
  std::string out;
  for (int x : v) out += (out.empty() ? "" : ",") + std::to_string(x);
  return out;
}

std::string plan_setting_label(const std::string& list, std::size_t i, const PlanSetting& s) {
  return list + "[" + std::to_string(i) + "] '" + s.name + "' (" + s.source + ")";
}

// The differences of two lists of settings, named by `list`.
void compare_plan_settings(const std::string& list, const std::vector<PlanSetting>& was,
                      const std::vector<PlanSetting>& now, std::vector<std::string>& out) {
  if (was.size() != now.size()) {
    out.push_back(list + " (" + std::to_string(was.size()) + " then, " + std::to_string(now.size()) + " now)");
    return;
  }
  for (std::size_t i = 0; i < was.size(); ++i) {
    if (was[i].sha256 == now[i].sha256) continue;
    std::string what = plan_setting_label(list, i, was[i]);
    if (was[i].source != now[i].source) what += ", now from " + now[i].source;
    if (was[i].name != now[i].name) what += ", now named '" + now[i].name + "'";
    out.push_back(what);
  }
}

}  // namespace

json PlanInputs::to_json() const {
  json j = {{"protocol_file", protocol_file},
          {"protocol_sha256", protocol_sha256},
          {"settings", plan_settings_json(settings)},
          {"staircase", plan_settings_json(staircase)},
          {"software", software},
          {"seed", std::to_string(seed)},  // a u64 is not a JSON number every reader keeps exact
          {"participants", participants},
          {"studies", studies},
          {"rate_Hz", rate_Hz},
          {"max_trial_s", max_trial_s},
          {"alpha", alpha},
          {"percentiles", percentiles},
          {"population", population},
          {"model_uncertainty", model_uncertainty}};
  // The whole plan's record has no "shard": a merged plan is the same as one
  // made on one machine.
  if (shards > 1) j["shard"] = {shard, shards};
  return j;
}

std::vector<std::pair<int, int>> PlanInputs::studies_of_plan() const {
  std::vector<std::pair<int, int>> out;
  for (int n : participants)
    for (int i = 0; i < studies; ++i) out.push_back({n, i});
  return out;
}

std::vector<std::pair<int, int>> PlanInputs::studies_of_shard() const {
  std::vector<std::pair<int, int>> all = studies_of_plan(), out;
  for (std::size_t k = static_cast<std::size_t>(shard); k < all.size(); k += static_cast<std::size_t>(shards))
    out.push_back(all[k]);
  return out;
}

int PlanInputs::shard_of(int n, int index) const {
  const auto at = std::find(participants.begin(), participants.end(), n);
  if (at == participants.end() || index < 0 || index >= studies) return -1;
  const std::size_t k = static_cast<std::size_t>(at - participants.begin()) * static_cast<std::size_t>(studies) +
                        static_cast<std::size_t>(index);
  return static_cast<int>(k % static_cast<std::size_t>(shards));
}

PlanInputs PlanInputs::whole() const {
  PlanInputs p = *this;
  p.shard = 0;
  p.shards = 1;
  return p;
}

PlanInputs PlanInputs::from_json(const json& j) {
  try {
    PlanInputs p;
    p.protocol_file = j.at("protocol_file").get<std::string>();
    p.protocol_sha256 = j.at("protocol_sha256").get<std::string>();
    p.settings = plan_settings_from(j.at("settings"));
    p.staircase = plan_settings_from(j.at("staircase"));
    p.software = j.at("software").get<std::string>();
    const std::string seed = j.at("seed").get<std::string>();
    const auto [end, ec] = std::from_chars(seed.data(), seed.data() + seed.size(), p.seed, 10);
    if (seed.empty() || ec != std::errc{} || end != seed.data() + seed.size())
      throw std::runtime_error("seed '" + seed + "' is not a whole number");
    p.participants = j.at("participants").get<std::vector<int>>();
    p.studies = j.at("studies").get<int>();
    p.rate_Hz = j.at("rate_Hz").get<double>();
    p.max_trial_s = j.at("max_trial_s").get<double>();
    p.alpha = j.at("alpha").get<double>();
    p.percentiles = j.at("percentiles").get<std::string>();
    p.population = j.at("population").get<std::string>();
    p.model_uncertainty = j.at("model_uncertainty").get<bool>();
    if (j.contains("shard")) {
      const auto shard = j.at("shard").get<std::vector<int>>();
      if (shard.size() != 2 || shard[1] < 2 || shard[0] < 0 || shard[0] >= shard[1])
        throw std::runtime_error("shard " + j.at("shard").dump() + " is not [I, N] with 0 <= I < N, N >= 2");
      p.shard = shard[0];
      p.shards = shard[1];
    }
    return p;
  } catch (const std::exception& e) {
    throw std::runtime_error(std::string("its record of the plan's inputs cannot be read (") + e.what() + ")");
  }
}

std::string PlanInputs::describe() const {
  std::string names;
  for (const PlanSetting& s : settings) names += (names.empty() ? "'" : ", '") + s.name + "'";
  return protocol_file + " (sha256 " + protocol_sha256.substr(0, 12) + "…) with settings " + names +
         (staircase.empty() ? "" : " and a staircase on '" + staircase.front().name + "'") + ", --seed " +
         std::to_string(seed) + ", --participants " + joined_counts(participants) + ", --studies " +
         std::to_string(studies) + ", --rate-hz " + format_number(rate_Hz) + ", --max-trial-s " +
         format_number(max_trial_s) + ", population " + population +
         (model_uncertainty ? " with the model's uncertainty" : "") + (shards > 1 ? ", --shard " + std::to_string(shard) + "/" + std::to_string(shards) : "") +
         ", by " + software;
}

PlanInputs plan_inputs(const protocols::Protocol& protocol, const std::string& protocol_file,
                       const std::string& protocol_text, std::uint64_t seed, std::vector<int> participants,
                       int studies, const SimulatedStudyOptions& options) {
  PlanInputs p;
  p.protocol_file = protocol_file;
  p.protocol_sha256 = sha256_hex(protocol_text);
  for (const protocols::ProtocolSetting& s : protocol.settings) p.settings.push_back(plan_setting_of(s));
  if (protocol.staircase) p.staircase.push_back(plan_setting_of(protocol.staircase->base));
  p.software = software_version();
  p.seed = seed;
  std::sort(participants.begin(), participants.end());
  participants.erase(std::unique(participants.begin(), participants.end()), participants.end());
  p.participants = std::move(participants);
  p.studies = studies;
  p.rate_Hz = options.rate_Hz;
  p.max_trial_s = options.max_trial_s;
  p.alpha = options.analysis.alpha;
  p.percentiles = std::string(analysis::percentile_method_name(options.analysis.percentile_method));
  return p;
}

std::vector<std::string> plan_differences(const PlanInputs& was, const PlanInputs& now) {
  std::vector<std::string> out;
  if (was.protocol_sha256 != now.protocol_sha256)
    out.push_back("the protocol's text (sha256 " + was.protocol_sha256.substr(0, 12) + "… then, " +
                  now.protocol_sha256.substr(0, 12) + "… now)");
  compare_plan_settings("settings", was.settings, now.settings, out);
  compare_plan_settings("staircase.settings", was.staircase, now.staircase, out);
  if (was.software != now.software) out.push_back("the software (" + was.software + " then, " + now.software + " now)");
  const auto option = [&](const std::string& name, const std::string& a, const std::string& b) {
    if (a != b) out.push_back(name + " (" + a + " then, " + b + " now)");
  };
  option("--seed", std::to_string(was.seed), std::to_string(now.seed));
  option("--participants", joined_counts(was.participants), joined_counts(now.participants));
  option("--studies", std::to_string(was.studies), std::to_string(now.studies));
  option("--rate-hz", format_number(was.rate_Hz), format_number(now.rate_Hz));
  option("--max-trial-s", format_number(was.max_trial_s), format_number(now.max_trial_s));
  option("alpha", format_number(was.alpha), format_number(now.alpha));
  option("the percentile method", was.percentiles, now.percentiles);
  option("the population (--population)", was.population, now.population);
  option("--model-uncertainty", was.model_uncertainty ? "on" : "off", now.model_uncertainty ? "on" : "off");
  option("--shard", std::to_string(was.shard) + "/" + std::to_string(was.shards),
         std::to_string(now.shard) + "/" + std::to_string(now.shards));
  return out;
}

void write_inputs_record(const std::filesystem::path& file, const PlanInputs& inputs, const nlohmann::json& extra) {
  nlohmann::json j = inputs.to_json();
  for (const auto& [key, value] : extra.items()) j[key] = value;
  write_file_atomically(file, j.dump(2) + "\n");
}

}  // namespace hapticlab::planning

#include "planning/population_file.h"

#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include "core/common/sha256.h"
#include "core/common/input_file.h"

namespace hapticlab::planning {

namespace {

using nlohmann::json;

json population_json(const PopulationParams& p) {
  json j = json::object();
  for (int i = 0; i < PopulationParams::kFields; ++i) j[p.field(i).first] = p.field(i).second;
  return j;
}

const char* kind_name(CalibrationTarget::Kind k) { return k == CalibrationTarget::Kind::kEvent ? "event" : "value"; }

json contents(const PopulationFile& f) {
  json j;
  j["format"] = kPopulationFormat;
  j["format_version"] = kPopulationFormatVersion;
  j["model_version"] = f.model_version;
  j["description"] = f.description;
  j["population"] = population_json(f.point);
  json free = json::array();
  for (const FreeParameter& p : f.free)
    free.push_back({{"name", p.name},
                    {"why", p.why},
                    {"prior", {{"low", p.prior_low}, {"high", p.prior_high}, {"scale", p.prior_log ? "log" : "linear"},
                               {"source", p.prior_source}}},
                    {"posterior", {{"mean", p.mean}, {"sd", p.sd}, {"interval95", {p.low95, p.high95}}}}});
  j["free_parameters"] = free;
  json fixed = json::array();
  for (const FixedParameter& p : f.fixed) fixed.push_back({{"name", p.name}, {"value", p.value}, {"source", p.source}});
  j["fixed_parameters"] = fixed;
  json columns = json::array();
  for (int i = 0; i < PopulationParams::kFields; ++i) columns.push_back(PopulationParams{}.field(i).first);
  json rows = json::array();
  for (const PopulationParams& d : f.draws) {
    json row = json::array();
    for (int i = 0; i < PopulationParams::kFields; ++i) row.push_back(d.field(i).second);
    rows.push_back(row);
  }
  j["posterior_draws"] = {{"columns", columns}, {"rows", rows}};
  json sources = json::array();
  for (const CalibrationSource& s : f.sources)
    sources.push_back({{"key", s.key}, {"citation", s.citation}, {"read", s.read}});
  json targets = json::array();
  for (const CalibrationTarget& t : f.targets) {
    json x = {{"id", t.id},   {"source", t.source},   {"where", t.where},
              {"published", t.published}, {"reading", t.reading}, {"kind", kind_name(t.kind)}};
    if (t.kind == CalibrationTarget::Kind::kValue) {
      x["value"] = t.value;
      x["sd"] = t.sd;
      x["sd_source"] = t.sd_source;
    }
    targets.push_back(x);
  }
  j["calibration_set"] = {{"sources", sources}, {"targets", targets}};
  j["fit"] = f.fit;
  return j;
}

std::string digest_of(const json& j) { return sha256_hex(j.dump()); }

[[noreturn]] void refuse(const std::filesystem::path& path, const std::string& why) {
  throw PopulationFileError("population file " + path.string() + ": " + why);
}

const json& member(const std::filesystem::path& path, const json& j, const char* key, const char* where) {
  if (!j.is_object() || !j.contains(key)) refuse(path, std::string(where) + key + " is missing (damaged?)");
  return j.at(key);
}

std::string text_member(const std::filesystem::path& path, const json& j, const char* key, const char* where) {
  const json& v = member(path, j, key, where);
  if (!v.is_string()) refuse(path, std::string(where) + key + " is not text (damaged?)");
  return v.get<std::string>();
}

double number_member(const std::filesystem::path& path, const json& j, const char* key, const char* where) {
  const json& v = member(path, j, key, where);
  if (!v.is_number() || !std::isfinite(v.get<double>()))
    refuse(path, std::string(where) + key + " is not a finite number (damaged?)");
  return v.get<double>();
}

PopulationParams population_from(const std::filesystem::path& path, const json& j, const std::string& where) {
  PopulationParams p;
  for (int i = 0; i < PopulationParams::kFields; ++i) {
    const char* name = p.field(i).first;
    p.set_field(name, number_member(path, j, name, (where + ".").c_str()));
  }
  try {
    p.validate();
  } catch (const std::invalid_argument& e) {
    refuse(path, where + ": " + e.what());
  }
  return p;
}

}  // namespace

std::string population_file_text(PopulationFile& file) {
  const json j = contents(file);
  file.sha256 = digest_of(j);
  json out = j;
  out["sha256"] = file.sha256;
  return out.dump(2) + "\n";
}

namespace {

// The file's JSON, after the checks that say whether it is a population
// file this hapticlab may use at all: format, versions, checksum.
json checked_document(const std::filesystem::path& path, int& model, std::string& stored) {
  // Bounded, as settings and protocol files are: /dev/zero given as a
  // population grew without limit. The shipped fit is 56 KB.
  constexpr std::size_t kMaxPopulationFileBytes = std::size_t{16} << 20;
  std::string text;
  try {
    text = read_text_file(path, kMaxPopulationFileBytes, "population file");
  } catch (const InputFileError& e) {
    const std::string what = e.what();
    const std::string prefix = path.string() + ": ";
    refuse(path, what.rfind(prefix, 0) == 0 ? what.substr(prefix.size()) : what);
  }
  json j;
  try {
    j = json::parse(text);
  } catch (const json::exception& e) {
    refuse(path, std::string("is not valid JSON (damaged?): ") + e.what());
  }
  if (!j.is_object()) refuse(path, "is not a JSON object (damaged?)");
  if (!j.contains("format") || j["format"] != kPopulationFormat)
    refuse(path, std::string("is not a population file (its \"format\" is not \"") + kPopulationFormat + "\")");
  if (!j.contains("format_version") || !j["format_version"].is_number_integer() ||
      j["format_version"].get<int>() != kPopulationFormatVersion)
    refuse(path, "has format_version " + (j.contains("format_version") ? j["format_version"].dump() : "(none)") +
                     ", but this hapticlab reads format_version " + std::to_string(kPopulationFormatVersion));
  if (!j.contains("model_version") || !j["model_version"].is_number_integer())
    refuse(path, "has no model_version, so which participant model it was fitted for is unknown");
  model = j["model_version"].get<int>();
  if (model != kParticipantModelVersion)
    refuse(path, "was fitted for participant model " + std::to_string(model) + ", but this hapticlab simulates model " +
                     std::to_string(kParticipantModelVersion) +
                     "; a population is not carried over between models: fit it again with `hapticlab plan "
                     "calibrate --fit --out DIR` (docs/simulation.md)");
  if (!j.contains("sha256") || !j["sha256"].is_string()) refuse(path, "has no sha256, so damage cannot be detected");
  stored = j["sha256"].get<std::string>();
  json body = j;
  body.erase("sha256");
  if (digest_of(body) != stored)
    refuse(path, "is damaged or was edited after the fit: its contents hash to " + digest_of(body) +
                     ", not to the sha256 it records (" + stored +
                     "); restore it, or fit again with `hapticlab plan calibrate --fit`");
  return j;
}

// The calibration set's sources: every source it relies on must be cited.
// Returns their keys.
std::set<std::string> read_sources(const std::filesystem::path& path, const json& set, PopulationFile& f) {
  const json& sources = member(path, set, "sources", "calibration_set.");
  if (!sources.is_array()) refuse(path, "calibration_set.sources is not a list (damaged?)");
  std::set<std::string> keys;
  for (const json& s : sources) {
    CalibrationSource c;
    c.key = text_member(path, s, "key", "calibration_set.sources[].");
    c.citation = text_member(path, s, "citation", ("calibration_set.sources[" + c.key + "].").c_str());
    c.read = text_member(path, s, "read", ("calibration_set.sources[" + c.key + "].").c_str());
    if (c.citation.empty())
      refuse(path, "calibration source '" + c.key + "' has no citation: a fit must say where its targets come from");
    keys.insert(c.key);
    f.sources.push_back(std::move(c));
  }
  for (const CalibrationSource& required : calibration_sources())
    if (!keys.count(required.key))
      refuse(path, "cites no source '" + required.key + "' (" + required.citation.substr(0, 60) +
                       "...), which the calibration set relies on; a population whose sources are missing is not "
                       "used");
  return keys;
}

// The calibration set's targets, each citing one of `keys`.
void read_targets(const std::filesystem::path& path, const json& set, const std::set<std::string>& keys,
                  PopulationFile& f) {
  const json& targets = member(path, set, "targets", "calibration_set.");
  if (!targets.is_array() || targets.empty()) refuse(path, "calibration_set.targets is empty or not a list");
  for (const json& t : targets) {
    CalibrationTarget c;
    c.id = text_member(path, t, "id", "calibration_set.targets[].");
    const std::string where = "calibration_set.targets[" + c.id + "].";
    c.source = text_member(path, t, "source", where.c_str());
    if (!keys.count(c.source))
      refuse(path, "target '" + c.id + "' cites source '" + c.source + "', which the file does not have");
    c.where = text_member(path, t, "where", where.c_str());
    c.published = text_member(path, t, "published", where.c_str());
    c.reading = text_member(path, t, "reading", where.c_str());
    if (c.where.empty() || c.published.empty())
      refuse(path, "target '" + c.id + "' does not say where in its source it stands or what was published");
    const std::string kind = text_member(path, t, "kind", where.c_str());
    if (kind == "value") {
      c.kind = CalibrationTarget::Kind::kValue;
      c.value = number_member(path, t, "value", where.c_str());
      c.sd = number_member(path, t, "sd", where.c_str());
      c.sd_source = text_member(path, t, "sd_source", where.c_str());
    } else if (kind != "event") {
      refuse(path, "target '" + c.id + "' has kind '" + kind + "'; allowed: event, value");
    }
    f.targets.push_back(std::move(c));
  }
}

// The free parameters (each with its prior's source) and the fixed ones.
void read_parameters(const std::filesystem::path& path, const json& j, PopulationFile& f) {
  const json& free = member(path, j, "free_parameters", "");
  if (!free.is_array() || free.empty()) refuse(path, "free_parameters is empty or not a list");
  for (const json& p : free) {
    FreeParameter x;
    x.name = text_member(path, p, "name", "free_parameters[].");
    if (!PopulationParams{}.set_field(x.name, 0.0))
      refuse(path, "free parameter '" + x.name + "' is not a population parameter");
    const std::string where = "free_parameters[" + x.name + "].";
    x.why = text_member(path, p, "why", where.c_str());
    const json& prior = member(path, p, "prior", where.c_str());
    x.prior_low = number_member(path, prior, "low", (where + "prior.").c_str());
    x.prior_high = number_member(path, prior, "high", (where + "prior.").c_str());
    x.prior_log = text_member(path, prior, "scale", (where + "prior.").c_str()) == "log";
    x.prior_source = text_member(path, prior, "source", (where + "prior.").c_str());
    if (x.prior_source.empty()) refuse(path, "free parameter '" + x.name + "' does not say where its prior comes from");
    const json& post = member(path, p, "posterior", where.c_str());
    x.mean = number_member(path, post, "mean", (where + "posterior.").c_str());
    x.sd = number_member(path, post, "sd", (where + "posterior.").c_str());
    f.free.push_back(std::move(x));
  }
  const json& fixed = member(path, j, "fixed_parameters", "");
  if (!fixed.is_array()) refuse(path, "fixed_parameters is not a list");
  for (const json& p : fixed) {
    FixedParameter x;
    x.name = text_member(path, p, "name", "fixed_parameters[].");
    x.value = number_member(path, p, "value", ("fixed_parameters[" + x.name + "].").c_str());
    x.source = text_member(path, p, "source", ("fixed_parameters[" + x.name + "].").c_str());
    f.fixed.push_back(std::move(x));
  }
}

// The posterior draws: a table of one column per population field.
void read_draws(const std::filesystem::path& path, const json& j, PopulationFile& f) {
  const json& draws = member(path, j, "posterior_draws", "");
  const json& columns = member(path, draws, "columns", "posterior_draws.");
  const json& rows = member(path, draws, "rows", "posterior_draws.");
  if (!columns.is_array() || !rows.is_array() || rows.empty())
    refuse(path, "posterior_draws has no rows: a fitted population carries its uncertainty as draws");
  for (std::size_t r = 0; r < rows.size(); ++r) {
    if (!rows[r].is_array() || rows[r].size() != columns.size())
      refuse(path, "posterior_draws row " + std::to_string(r) + " does not have one value per column (damaged?)");
    json as_object = json::object();
    for (std::size_t c = 0; c < columns.size(); ++c) {
      if (!columns[c].is_string()) refuse(path, "posterior_draws.columns holds a non-text name (damaged?)");
      as_object[columns[c].get<std::string>()] = rows[r][c];
    }
    f.draws.push_back(population_from(path, as_object, "posterior_draws row " + std::to_string(r)));
  }
}

}  // namespace

PopulationFile read_population_file(const std::filesystem::path& path) {
  PopulationFile f;
  std::string stored;
  const json j = checked_document(path, f.model_version, stored);
  f.sha256 = stored;
  f.description = text_member(path, j, "description", "");
  f.point = population_from(path, member(path, j, "population", ""), "population");
  const json& set = member(path, j, "calibration_set", "");
  const std::set<std::string> keys = read_sources(path, set, f);
  read_targets(path, set, keys, f);
  read_parameters(path, j, f);
  read_draws(path, j, f);
  f.fit = j.contains("fit") ? j["fit"] : json::object();
  return f;
}

}  // namespace hapticlab::planning

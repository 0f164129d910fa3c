#include "app/plan/stability_command.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "analysis/report/gnuplot.h"
#include "app/cli/cli_checks.h"
#include "app/cli/data_paths.h"
#include "app/cli/progress_line.h"
#include "app/cli/option_shapes.h"
#include "core/common/csv_format.h"
#include "core/common/output_file.h"
#include "core/settings/settings_json.h"
#include "core/sim/stability_map.h"
#include "planning/plan_folder.h"

namespace hapticlab::app {
namespace {

namespace fs = std::filesystem;

// A map expected to take longer than this asks for --yes first: the issue's
// five minutes, which the default map keeps well within (BENCHMARKS.md).
constexpr double kConfirmAbove_s = 300.0;

struct StabilityOptions {
  std::string settings;
  std::vector<double> rates_Hz{150, 300, 500, 1000, 2000};
  std::vector<std::string> effects;
  std::vector<double> stiffnesses_N_per_m{320, 2000};
  std::string contact = "grasped";
  double duration_s = 3.0;
  double max_oscillation_mm = 0.5;
  double max_energy_mJ = 20.0;
  int steps = 12;
  std::size_t jobs = 0;
  std::string out = "stability-map";
  bool plots = true;
  bool yes = false;
};

std::string sig3(double v) {
  if (std::isnan(v)) return "";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

const char* kind_name(BoundaryKind k) {
  switch (k) {
    case BoundaryKind::kStableBelow: return "stable_below";
    case BoundaryKind::kStableAbove: return "stable_above";
    case BoundaryKind::kStableEverywhere: return "stable_everywhere";
    case BoundaryKind::kUnstableEverywhere: return "unstable_everywhere";
  }
  return "";
}

bool found(const Boundary& b) {
  return b.kind == BoundaryKind::kStableBelow || b.kind == BoundaryKind::kStableAbove;
}

// A stable base: its stable interval, "0.05 – 0.64", "≤ 0.64" (stable down
// to the range's end), "≥ 0.05", "all". An unstable base: "✗" and the
// nearest stable values each side, "✗ ≤ 0.01, ≥ 0.64", or "✗ none".
std::string cell_text(const StabilityCell& c) {
  if (c.base_stable) {
    const bool low_open = c.below.kind == BoundaryKind::kStableEverywhere;
    const bool high_open = c.above.kind == BoundaryKind::kStableEverywhere;
    if (low_open && high_open) return "all";
    if (low_open) return "≤ " + sig3(c.above.stable);
    if (high_open) return "≥ " + sig3(c.below.stable);
    return sig3(c.below.stable) + " – " + sig3(c.above.stable);
  }
  std::string s;
  if (c.below.kind == BoundaryKind::kStableBelow) s = "≤ " + sig3(c.below.stable);
  if (c.above.kind == BoundaryKind::kStableAbove) s += (s.empty() ? "≥ " : ", ≥ ") + sig3(c.above.stable);
  return "✗ " + (s.empty() ? std::string("none") : s);
}

std::vector<StabilityParameter> chosen_parameters(const std::vector<std::string>& effects) {
  const std::vector<StabilityParameter> all = default_stability_parameters();
  if (effects.empty()) return all;
  std::vector<StabilityParameter> out;
  for (const std::string& e : effects) {
    std::size_t matched = 0;
    for (const StabilityParameter& p : all)
      if (stability_effect(p) == e || p.field == e) {
        if (std::none_of(out.begin(), out.end(), [&](const StabilityParameter& q) { return q.field == p.field; }))
          out.push_back(p);
        ++matched;
      }
    if (matched == 0) {
      std::string names = "inertia, backlash, cogging, friction";
      for (const StabilityParameter& p : all) names += ", " + p.field;
      throw CLI::ValidationError("--effects", "'" + e + "' is not one of: " + names);
    }
  }
  return out;
}

// The base column: the value, or for an effect the base settings have off
// the value its disabled block holds, which the map started from with the
// effect switched on (not a value of the base settings).
std::string base_text(const StabilityCell& c) {
  return c.base_effect_on ? sig3(c.base_value) : "off (map from " + sig3(c.base_value) + ")";
}

std::string contact_title(const StabilityOptions& o, double k) {
  return (o.contact == "wall" ? "Wall, " : "Grasped tissue, ") + format_number(k) + " N/m";
}

std::string markdown(const StabilityOptions& o, const StabilityMapConfig& config, const StabilityMap& map,
                     const std::string& settings_name) {
  std::ostringstream md;
  md << "# Stability map of " << settings_name << "\n\n"
     << "Each parameter varied alone, every other one at its value in " << settings_name
     << "; stable when the tip moves at most " << format_number(o.max_oscillation_mm)
     << " mm peak to peak over the last second of " << format_number(o.duration_s)
     << " s and the device gives the hand at most " << format_number(o.max_energy_mJ)
     << " mJ net (docs/engine.md, \"Stability map\"). A cell is the stable interval around the base value, "
        "bounded by the nearest change each side: `a – b`; `≤ b` when it reaches down to the range's end; "
        "`≥ a` up to it; `all` both. `✗`: the base value itself is unstable; then the nearest stable value "
        "each side (`≤ a`, `≥ b`), or `none`.";
  if (std::any_of(map.cells.begin(), map.cells.end(), [](const StabilityCell& c) { return !c.base_effect_on; }))
    md << " A base of `off (map from v)`: the parameter's effect is off in " << settings_name
       << "; its rows have it switched on, starting from the value v its settings block holds.";
  md << '\n';
  for (double k : config.stiffnesses_N_per_m) {
    md << "\n## " << contact_title(o, k) << "\n";
    for (bool controller : {false, true}) {
      md << "\n### " << (controller ? "With the passivity controller (its defaults)" : "Without the passivity controller")
         << "\n\n| parameter | range | base |";
      for (double r : config.rates_Hz) md << ' ' << format_number(r) << " Hz |";
      md << "\n| --- | --- | --- |";
      for (std::size_t i = 0; i < config.rates_Hz.size(); ++i) md << " --- |";
      md << "\n| the base settings themselves | | |";
      for (double r : config.rates_Hz)
        for (const StabilityBaseRun& b : map.base_runs)
          if (b.rate_Hz == r && b.stiffness_N_per_m == k && b.controller == controller)
            md << ' ' << (b.stable ? "stable" : "**unstable**") << ", " << sig3(1e3 * b.result.oscillation_m)
               << " mm, " << sig3(1e3 * b.result.device_net_J) << " mJ |";
      md << '\n';
      for (std::size_t p = 0; p < config.parameters.size(); ++p) {
        bool first = true;
        for (double r : config.rates_Hz)
          for (const StabilityCell& c : map.cells)
            if (c.parameter == p && c.rate_Hz == r && c.stiffness_N_per_m == k && c.controller == controller) {
              const BoundarySearch& range = config.parameters[p].range;
              if (first)
                md << "| `" << config.parameters[p].field << "` | " << sig3(range.lo) << " – " << sig3(range.hi)
                   << " | " << base_text(c) << " |";
              first = false;
              md << ' ' << cell_text(c) << " |";
            }
        md << '\n';
      }
    }
  }
  return md.str();
}

std::string cells_csv(const StabilityOptions& o, const StabilityMapConfig& config, const StabilityMap& map) {
  auto number = [](double v) { return std::isnan(v) ? std::string() : format_number(v); };
  std::ostringstream csv;
  csv << "field,effect,contact,stiffness_N_per_m,rate_Hz,controller,range_lo,range_hi,base_value,base_stable,"
         "below_kind,below_stable,below_unstable,above_kind,above_stable,above_unstable,base_effect\n";
  for (const StabilityCell& c : map.cells) {
    const StabilityParameter& p = config.parameters[c.parameter];
    csv << p.field << ',' << stability_effect(p) << ',' << o.contact << ',' << format_number(c.stiffness_N_per_m)
        << ',' << format_number(c.rate_Hz) << ',' << (c.controller ? "on" : "off") << ','
        << format_number(p.range.lo) << ',' << format_number(p.range.hi) << ',' << format_number(c.base_value)
        << ',' << (c.base_stable ? 1 : 0);
    for (const Boundary* b : {&c.below, &c.above})
      csv << ',' << kind_name(b->kind) << ',' << number(b->stable) << ',' << number(b->unstable);
    csv << ',' << (c.base_effect_on ? "on" : "off") << '\n';
  }
  return csv.str();
}

std::string base_csv(const StabilityOptions& o, const StabilityMap& map) {
  std::ostringstream csv;
  csv << "contact,stiffness_N_per_m,rate_Hz,controller,oscillation_m,device_net_J,faulted,stable\n";
  for (const StabilityBaseRun& b : map.base_runs)
    csv << o.contact << ',' << format_number(b.stiffness_N_per_m) << ',' << format_number(b.rate_Hz) << ','
        << (b.controller ? "on" : "off") << ',' << format_number(b.result.oscillation_m) << ','
        << format_number(b.result.device_net_J) << ',' << (b.result.faulted ? 1 : 0) << ',' << (b.stable ? 1 : 0)
        << '\n';
  return csv.str();
}

// One figure per parameter: the boundaries found above and below the base
// value against the rate, per stiffness and controller state, the base
// value as a horizontal line. Where no boundary lies on a side the line has
// a gap (the table says why).
std::vector<std::string> draw(const fs::path& dir, const StabilityMapConfig& config, const StabilityMap& map) {
  analysis::GnuplotScript script;
  for (std::size_t p = 0; p < config.parameters.size(); ++p) {
    const StabilityParameter& param = config.parameters[p];
    std::string block = "map_";
    for (char ch : param.field) block += std::isalnum(static_cast<unsigned char>(ch)) ? ch : '_';
    std::ostringstream data;
    std::vector<std::string> titles;
    double base = 0.0;
    bool base_on = true;
    for (double k : config.stiffnesses_N_per_m)
      for (bool controller : {false, true}) {
        for (const StabilityCell& c : map.cells)
          if (c.parameter == p && c.stiffness_N_per_m == k && c.controller == controller) {
            base = c.base_value;
            base_on = c.base_effect_on;
            data << format_number(c.rate_Hz) << ' ' << (found(c.below) ? format_number(c.below.stable) : "NaN")
                 << ' ' << (found(c.above) ? format_number(c.above.stable) : "NaN") << '\n';
          }
        data << "\n\n";
        titles.push_back(format_number(k) + " N/m, controller " + (controller ? "on" : "off"));
      }
    script.add_datablock(block, data.str());
    std::string plot = "set termoption noenhanced\nset title " +
                       analysis::gnuplot_quote(param.field + ": nearest stability boundaries above and below the "
                                                             "base value") +
                       "\nset xlabel 'update rate [Hz]'\nset ylabel " + analysis::gnuplot_quote(param.field) +
                       "\nset logscale x\nset xrange [100:3000]\nset key below horizontal maxcols 2\nset grid\n" +
                       (param.range.geometric ? "set logscale y\n" : "") + "plot ";
    // Colour per condition; the boundary below the base value dashed with
    // triangles down, the one above solid with triangles up.
    for (std::size_t i = 0; i < titles.size(); ++i) {
      const std::string series = "$" + block + " index " + std::to_string(i);
      const std::string colour = " lc " + std::to_string(i + 1);
      plot += series + " using 1:3 with linespoints lw 2 pt 9" + colour + " title " +
              analysis::gnuplot_quote(titles[i] + ", above the base") + ", " + series +
              " using 1:2 with linespoints lw 2 dt 2 pt 11" + colour + " title " +
              analysis::gnuplot_quote(titles[i] + ", below the base") + ", ";
    }
    plot += format_number(base) + " with lines lc 'black' dt 3 title " +
            (base_on ? "'base value'" : "'start value (the effect is off in the base settings)'");
    script.add_plot(block + ".svg", plot, 900, 560);
  }
  analysis::run_gnuplot(script, dir, analysis::find_gnuplot());
  return script.outputs();
}

StabilityMapConfig stability_config(const StabilityOptions& o, const NamedSettings& named) {
  StabilityMapConfig config;
  config.base = named.engine;
  config.rates_Hz = o.rates_Hz;
  std::sort(config.rates_Hz.begin(), config.rates_Hz.end());
  config.rates_Hz.erase(std::unique(config.rates_Hz.begin(), config.rates_Hz.end()), config.rates_Hz.end());
  // Stiffnesses as rates: sorted, a repeated one mapped once.
  config.stiffnesses_N_per_m = o.stiffnesses_N_per_m;
  std::sort(config.stiffnesses_N_per_m.begin(), config.stiffnesses_N_per_m.end());
  config.stiffnesses_N_per_m.erase(std::unique(config.stiffnesses_N_per_m.begin(), config.stiffnesses_N_per_m.end()),
                                   config.stiffnesses_N_per_m.end());
  config.contact = o.contact == "wall" ? StiffContactKind::kWall : StiffContactKind::kGraspedTissue;
  config.parameters = chosen_parameters(o.effects);
  for (StabilityParameter& p : config.parameters) p.range.steps = o.steps;
  config.criterion.max_oscillation_m = o.max_oscillation_mm * 1e-3;
  config.criterion.max_energy_J = o.max_energy_mJ * 1e-3;
  config.duration_s = o.duration_s;
  return config;
}

// An --effects list for what is left after leaving out the fields `refused`:
// an effect's name where all of its chosen fields remain, else the fields.
std::string effects_without(const std::vector<StabilityParameter>& chosen, const std::vector<std::string>& refused) {
  auto kept = [&](const StabilityParameter& p) {
    return std::find(refused.begin(), refused.end(), p.field) == refused.end();
  };
  std::string list;
  std::vector<std::string> named;
  for (const StabilityParameter& p : chosen) {
    if (!kept(p)) continue;
    const std::string effect = stability_effect(p);
    const bool whole = std::all_of(chosen.begin(), chosen.end(), [&](const StabilityParameter& q) {
      return stability_effect(q) != effect || kept(q);
    });
    const std::string item = whole ? effect : p.field;
    if (std::find(named.begin(), named.end(), item) != named.end()) continue;
    named.push_back(item);
    list += (list.empty() ? "" : ",") + item;
  }
  return list;
}

// Every effect the map varies is switched on for its runs. One the base
// settings cannot have on (backlash needs inertia) is refused here, before
// the timing runs and --out, instead of failing part way through the map.
void refuse_effects_the_base_cannot_have_on(const StabilityMapConfig& config, const fs::path& settings_path,
                                            const std::string& name) {
  std::vector<std::string> fields;
  std::string problems, needs;
  for (const StabilityParameter& p : config.parameters) {
    const std::string why = stability_parameter_problem(config.base, p);
    if (why.empty()) continue;
    fields.push_back(p.field);
    const std::vector<std::string> path = split_settings_field(p.field);
    const std::string block = path.size() > 1 ? path[0] + "." + path[1] : p.field;
    if (problems.find(block + " cannot") != std::string::npos) continue;
    problems += (problems.empty() ? "" : "; ") + block + " cannot be switched on (" + why + ")";
    // "... needs 'translation.inertia' enabled: ..." -> "'translation.inertia' enabled", for the way out.
    const std::size_t at = why.find(" needs "), end = why.find(':', at == std::string::npos ? 0 : at);
    if (at != std::string::npos && end != std::string::npos)
      needs += (needs.empty() ? "" : " and ") + why.substr(at + 7, end - at - 7);
  }
  if (fields.empty()) return;
  std::string listed;
  for (const std::string& f : fields) listed += (listed.empty() ? "" : ", ") + f;
  const std::string rest = effects_without(config.parameters, fields);
  throw CLI::ValidationError(
      "--effects", "the map switches on the effect of every parameter it varies, but in the base settings file " +
                       settings_path.string() + " (" + name + ") " + problems + ". Either pass --effects without " +
                       listed + (rest.empty() ? "" : " (e.g. --effects " + rest + ")") +
                       ", or a base settings file (--settings) " +
                       (needs.empty() ? "in which those effects can be switched on" : "with " + needs));
}

// The time per device update on this machine, the least of three runs of
// the base settings (one run is too noisy on a shared machine).
double stability_per_update_s(const StabilityMapConfig& config) {
  StiffContactConfig probe;
  probe.settings = config.base;
  probe.kind = config.contact;
  probe.stiffness_N_per_m = config.stiffnesses_N_per_m.front();
  probe.duration_s = 1.5;
  double per_update_s = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 3; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    (void)run_stiff_contact(probe);
    per_update_s = std::min(per_update_s, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() /
                                              (probe.duration_s * probe.rate_Hz));
  }
  return per_update_s;
}

// The whole map estimated before starting it, printed, and refused without
// --yes when large. The estimate counts every run the map may need;
// marches that stop early make it finish sooner.
void announce_stability_map(const StabilityOptions& o, const StabilityMapConfig& config, const std::string& name,
                            std::size_t cores) {
  const StabilityMapSize size = stability_map_size(config);
  const double per_update_s = stability_per_update_s(config);
  const double estimate_s = size.updates * per_update_s / static_cast<double>(std::min(config.jobs, cores));
  std::printf("Stability map of %s: %zu parameters x %zu rates x %zu stiffnesses x controller off/on, at most %ld "
              "runs of %s s; at most about %s on %zu threads\n",
              name.c_str(), config.parameters.size(), config.rates_Hz.size(), config.stiffnesses_N_per_m.size(),
              size.runs, format_number(config.duration_s).c_str(), format_duration(estimate_s).c_str(), config.jobs);
  std::fflush(stdout);
  if (estimate_s > kConfirmAbove_s && !o.yes)
    throw std::runtime_error("the grid is large: up to " + std::to_string(size.runs) + " runs, estimated " +
                             format_duration(estimate_s) + " on this machine, measured at " +
                             sig3(per_update_s * 1e6) + " us per update. Pass --yes to run it anyway, or make it "
                             "smaller (--rates, --effects, --stiffness, --steps, --duration-s)");
}

void run(const StabilityOptions& o) {
  const fs::path settings_path = o.settings.empty() ? default_settings_dir() / "max_stable.json" : fs::path(o.settings);
  const NamedSettings named = load_settings_file(settings_path);
  StabilityMapConfig config = stability_config(o, named);
  refuse_effects_the_base_cannot_have_on(config, settings_path, named.name);
  const std::size_t cores = std::max(1u, std::thread::hardware_concurrency());
  config.jobs = o.jobs == 0 ? cores : o.jobs;
  announce_stability_map(o, config, named.name, cores);

  // Made and proven writable now, not found unusable after the whole map.
  planning::prepare_plan_folder(o.out);
  ProgressLine line(stdout);
  const auto start = std::chrono::steady_clock::now();
  const StabilityMap map = run_stability_map(config, [&](std::size_t done, std::size_t total) {
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const double fraction = static_cast<double>(done) / static_cast<double>(total);
    line.update(fraction, "stability map", elapsed,
                done > 0 ? std::optional<double>(elapsed * (1.0 - fraction) / fraction) : std::nullopt);
  });
  line.finish();
  const double took_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  const std::string md = markdown(o, config, map, named.name);
  write_file_atomically(fs::path(o.out) / "stability_map.md", md);
  write_file_atomically(fs::path(o.out) / "stability_map.csv", cells_csv(o, config, map));
  write_file_atomically(fs::path(o.out) / "stability_base.csv", base_csv(o, map));
  std::fputs(md.c_str(), stdout);
  std::printf("\n%ld runs in %s. Tables: %s/stability_map.md, stability_map.csv, stability_base.csv\n", map.runs,
              format_duration(took_s).c_str(), o.out.c_str());
  if (o.plots) {
    const std::vector<std::string> figures = draw(o.out, config, map);
    std::printf("Figures: %zu in %s (one per parameter, plots.gp to redraw them)\n", figures.size(), o.out.c_str());
  }
}

}  // namespace

void add_stability_command(CLI::App& app) {
  CLI::App* stability = app.add_subcommand("stability", "Where the degradations stay stable in stiff contact");
  stability->require_subcommand(1);
  auto opt = std::make_shared<StabilityOptions>();
  CLI::App* cmd = stability->add_subcommand(
      "map",
      "Table 4.1 for any update rate: the simulated hand holds the tool in stiff contact, and for every rate the "
      "largest (or smallest) stable value of each effect parameter is found by bisection, the others kept at the "
      "base settings' values, with and without the passivity controller. Deterministic. Writes tables and "
      "figures to --out");
  cmd->add_option("--settings", opt->settings,
                  "Base settings (default: the shipped max_stable.json, Table 4.1's set, everything on)")
      ->check(CLI::ExistingFile);
  add_list_option(*cmd, "--rates", opt->rates_Hz, "Update rates [Hz], comma-separated, each 150..2000",
                  number_in(150.0, 2000.0))
      ->default_str("150,300,500,1000,2000");
  add_list_option(*cmd, "--effects", opt->effects,
                  "Effects (inertia, backlash, cogging, friction) or settings fields to map, comma-separated "
                  "(default: all of Table 4.1's parameters and friction's level)");
  add_list_option(*cmd, "--stiffness", opt->stiffnesses_N_per_m,
                  "The VE's stiffness [N/m], comma-separated, each 0.001..1e6 (default 320: the dissection "
                  "task's stiffest tissue; 2000: a firm rendered wall)",
                  number_in(1e-3, 1e6))
      ->default_str("320,2000");
  cmd->add_option("--contact", opt->contact,
                  "grasped: the tip tied to tissue, the thesis' unstable case; wall: pressed into a plane")
      ->capture_default_str()
      ->check(CLI::IsMember({"grasped", "wall"}));
  cmd->add_option("--duration-s", opt->duration_s, "Length of every run [s], 1.5..600; the last second is judged")
      ->capture_default_str()
      ->check(number_in(1.5, 600.0));
  cmd->add_option("--max-oscillation-mm", opt->max_oscillation_mm, "Stable: tip peak to peak at most this [mm]")
      ->capture_default_str()
      ->check(positive_number());
  cmd->add_option("--max-energy-mJ", opt->max_energy_mJ, "Stable: net energy given to the hand at most this [mJ]")
      ->capture_default_str()
      ->check(positive_number());
  cmd->add_option("--steps", opt->steps, "Bisection steps per boundary, 1..40")
      ->capture_default_str()
      ->check(whole_number_in(1, 40));
  add_jobs_option(*cmd, opt->jobs, "Threads (0: one per core); the map does not depend on it")->capture_default_str();
  cmd->add_option("--out", opt->out, "Folder for the tables and figures")->capture_default_str();
  cmd->add_flag("--no-plots", [opt](std::int64_t) { opt->plots = false; }, "No figures (no gnuplot needed)");
  cmd->add_flag("--yes", opt->yes, "Run a map estimated to take over 5 minutes without asking");
  cmd->callback([opt] { run(*opt); });
}

}  // namespace hapticlab::app

// `hapticlab plan merge`: its options, then the shards checked and merged
// (planning/plan_merge.h) and the merged plan's results printed.
#include "app/plan/plan_subcommands.h"

#include <cstdio>
#include <memory>

#include "app/plan/plan_results_print.h"
#include "planning/plan_merge.h"

namespace hapticlab::app {
namespace {

struct PlanMergeOptions {
  planning::PlanMergeRequest request;
  bool json = false;
};

int run_plan_merge(const PlanMergeOptions& o) {
  const planning::PlanMerge m = planning::merge_plan_shards(
      o.request, [](const std::string& note) { std::fprintf(stderr, "note: %s\n", note.c_str()); });
  char did[200];
  std::snprintf(did, sizeof did, "%zu shards merged: %zu studies (%zu added now, %zu already in %s)",
                o.request.shards.size(), m.studies, m.added, m.already, m.store.c_str());
  print_plan_results(m.protocol, m.whole, m.design, m.results, o.request.measure, o.json,
                     {did, 0.0, 0, "population " + m.whole.population});
  return 0;
}

}  // namespace

void add_plan_merge_subcommand(CLI::App* plan) {
  auto mo = std::make_shared<PlanMergeOptions>();
  planning::PlanMergeRequest& r = mo->request;
  CLI::App* merge = plan->add_subcommand(
      "merge",
      "Join the folders of one plan's shards (plan power --shard I/N, e.g. a Slurm job array) into one plan: checks "
      "they are the shards of one plan (protocol, settings, options, seed, version), each once and all of them, "
      "complete and undamaged, then writes what a one-machine run of the plan writes (power.csv, comparison.md, "
      "predicted_change.csv, figures), byte for byte. The shards' folders are only read.");
  merge->add_option("shards", r.shards, "The shards' --out folders")->required()->check(CLI::ExistingDirectory);
  merge->add_option("--out", r.out, "Folder for the merged plan (not one of the shards')")->required();
  merge->add_option("--protocol", r.protocol,
                    "The protocol file, when it is not where the shards' runs read it (its text and settings must be "
                    "the same)")
      ->check(CLI::ExistingFile);
  add_plan_measure_option(merge, r.measure);
  merge->add_flag("--no-plots", [mo](std::int64_t) { mo->request.plots = false; }, "No figures (no gnuplot needed)");
  merge->add_flag("--json", mo->json, "Print the power table as JSON");
  merge->callback([mo] {
    const int status = run_plan_merge(*mo);
    if (status != 0) throw CLI::RuntimeError(status);
  });
}

}  // namespace hapticlab::app

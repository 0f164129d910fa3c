#include "analysis/learning/learning_figures.h"

#include <algorithm>
#include <map>
#include <sstream>

#include "analysis/report/gnuplot.h"

namespace hapticlab::analysis::learning {
namespace {

std::string quoted_title(const ParticipantLearning& p) { return gnuplot_quote(p.participant + " (" + p.group + ")"); }

}  // namespace

std::vector<std::string> write_learning_figures(const LearningAnalysis& a, const std::filesystem::path& dir,
                                                const std::filesystem::path& gnuplot) {
  GnuplotScript script;
  const std::string ylabel = gnuplot_quote(a.measure);
  for (std::size_t k = 0; k < a.participants.size(); ++k) {
    const auto& p = a.participants[k];
    std::ostringstream data;
    data.precision(10);
    for (std::size_t i = 0; i < p.trial.size(); ++i) data << p.trial[i] << ' ' << p.value[i] << '\n';
    std::string fit_title = "no fit (" + std::string(p.curve.fits[0].ok() ? "" : refusal_name(p.curve.fits[0].refusal)) + ")";
    if (p.curve.chosen) {
      const CurveFit& f = p.curve.fit(*p.curve.chosen);
      data << "\n\n";
      const double hi = p.trial.back();
      for (int s = 0; s <= 200; ++s) {
        const double n = 1.0 + (hi - 1.0) * s / 200.0;
        data << n << ' ' << f.predict(n) << '\n';
      }
      std::ostringstream t;
      t.precision(3);
      t << family_name(f.family) << " fit, plateau " << f.a;
      fit_title = t.str();
    }
    const std::string block = "curve_" + std::to_string(k + 1);
    script.add_datablock(block, data.str());
    std::ostringstream cmd;
    cmd << "set title " << quoted_title(p) << "\nset xlabel 'trial'\nset ylabel " << ylabel
        << "\nset grid\nset key top right\nplot $" << block << " index 0 with points pt 7 title 'trials'";
    if (p.curve.chosen) cmd << ", $" << block << " index 1 with lines lw 2 title " << gnuplot_quote(fit_title);
    cmd << "\n";
    script.add_plot(block + ".svg", cmd.str());
    if (p.cusum) {
      std::ostringstream c;
      c.precision(10);
      c << "0 0\n";
      for (std::size_t i = 0; i < p.trial.size(); ++i) c << i + 1 << ' ' << p.cusum->score[i] << '\n';
      const std::string cb = "cusum_" + std::to_string(k + 1);
      script.add_datablock(cb, c.str());
      std::ostringstream cc;
      cc << "set title " << gnuplot_quote("CUSUM: " + p.participant + " (" + p.group + ")")
         << "\nset xlabel 'trial'\nset ylabel 'CUSUM score (failure +1-s, success -s)'\nset grid\nset key outside right\n"
         << "plot $" << cb << " with steps lw 2 title 'score', " << p.cusum->h1 << " with lines dt 2 title 'h1 (p1: unacceptable)', "
         << -p.cusum->h0 << " with lines dt 3 title '-h0 (p0: acceptable)'\n";
      script.add_plot(cb + ".svg", cc.str());
    }
  }
  // Group medians at each trial index.
  std::map<std::string, std::map<double, std::vector<double>>> by_group;
  for (const auto& p : a.participants)
    for (std::size_t i = 0; i < p.trial.size(); ++i) by_group[p.group][p.trial[i]].push_back(p.value[i]);
  std::ostringstream data, plot;
  plot << "set title " << gnuplot_quote("Group medians over trials: " + a.measure) << "\nset xlabel 'trial'\nset ylabel "
       << ylabel << "\nset grid\nset key outside right\nplot ";
  std::size_t index = 0;
  for (auto& [group, trials] : by_group) {
    if (index > 0) {
      data << "\n\n";
      plot << ", ";
    }
    for (auto& [n, values] : trials) {
      std::sort(values.begin(), values.end());
      const std::size_t m = values.size();
      const double med = m % 2 == 1 ? values[m / 2] : 0.5 * (values[m / 2 - 1] + values[m / 2]);
      data << n << ' ' << med << '\n';
    }
    plot << "$group_medians index " << index << " with linespoints lw 2 title " << gnuplot_quote(group);
    ++index;
  }
  script.add_datablock("group_medians", data.str());
  script.add_plot("group_medians.svg", plot.str() + "\n");
  run_gnuplot(script, dir, gnuplot, 1);
  std::vector<std::string> files = script.outputs();
  files.push_back("plots.gp");
  return files;
}

}  // namespace hapticlab::analysis::learning

#pragma once
// Plots through gnuplot (Debian package gnuplot-nox). A report's figures are
// one script; run_gnuplot splits it over a few gnuplot processes that draw
// side by side (one per core), each given only the datablocks its figures
// use. One process per figure would not pay: starting gnuplot costs tens of
// milliseconds, drawing one SVG far less.
//
// The whole script is kept next to the figures (plots.gp) so a user can
// restyle a figure and rerun `gnuplot plots.gp` in that directory.
#include <cstddef>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace hapticlab::analysis {

// Finds gnuplot: $HAPTICLAB_GNUPLOT if set, else `gnuplot` on PATH. Throws
// DataError saying how to install it when there is none.
std::filesystem::path find_gnuplot();

class GnuplotScript {
 public:
  // Data shared by later plots, as a named datablock ($name), rows of
  // whitespace-separated columns; datasets separated by two blank lines
  // (gnuplot's `index`). `name` is letters, digits and '_' only.
  void add_datablock(const std::string& name, const std::string& rows);
  // One figure: `commands` (set ..., plot ...) drawn into `svg_name`, a file
  // name relative to the script's directory. Every plot starts from `reset`.
  void add_plot(const std::string& svg_name, const std::string& commands, int width_px = 640,
                int height_px = 420);
  // Also draw every later plot as a PDF beside its SVG (same name, .pdf;
  // pdfcairo, sized as the SVG at 96 px per inch), for a paper.
  void set_pdf(bool pdf) { pdf_ = pdf; }
  const std::vector<std::string>& outputs() const { return outputs_; }
  const std::vector<std::string>& pdf_outputs() const { return pdf_outputs_; }
  // The whole script, datablocks and plots in the order they were added.
  std::string text() const;
  // The plots dealt into at most `parts` scripts (none empty) of about equal
  // work, each holding the datablocks its plots name ($name) and its plots
  // in their original order. Work is counted as the bytes of data a plot
  // reads plus a fixed cost per plot; the split is deterministic.
  std::vector<std::string> split(std::size_t parts) const;

 private:
  struct Datablock {
    std::string name;
    std::string text;  // "$name << EOD ... EOD"
  };
  struct Plot {
    std::string text;                  // reset ... unset output
    std::vector<std::size_t> blocks;   // indices into blocks_ it names
  };
  std::vector<Datablock> blocks_;
  std::vector<Plot> plots_;
  // Order of everything added: (is_plot, index) pairs, for text().
  std::vector<std::pair<bool, std::size_t>> order_;
  std::vector<std::string> outputs_;
  std::vector<std::string> pdf_outputs_;
  bool pdf_ = false;
};

// Runs the script in a staging directory inside `dir`, split over `jobs`
// gnuplot processes at once (0: one per core; never more than there are
// plots), then moves the figures and the whole script (plots.gp) into `dir`:
// all of them, or none when any gnuplot fails or an SVG is missing or
// truncated (DataError with gnuplot's own messages). The figures are the same
// bytes whatever `jobs` is.
void run_gnuplot(const GnuplotScript& script, const std::filesystem::path& dir,
                 const std::filesystem::path& gnuplot, std::size_t jobs = 0);

// The <svg> element of a gnuplot SVG file without the XML prolog, ready to
// sit inside HTML, with every id (gnuplot_canvas, the point symbols gpPt0...)
// and every reference to one (href='#id', url(#id)) prefixed by `id_prefix`:
// gnuplot gives every figure the same ids, and an HTML page with several
// figures must not repeat one.
std::string inline_svg(const std::string& svg, const std::string& id_prefix);

// Quotes a string for a gnuplot script ("..." with \ and " escaped).
std::string gnuplot_quote(const std::string& s);

}  // namespace hapticlab::analysis

#pragma once
// Plots through gnuplot (Debian package gnuplot-nox), driven by one script
// and one gnuplot process for all of a report's figures: starting gnuplot
// costs tens of milliseconds, drawing one SVG far less.
//
// The script is kept next to the figures (plots.gp) so a user can restyle a
// figure and rerun `gnuplot plots.gp` in that directory.
#include <filesystem>
#include <string>
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
  std::string text() const { return text_; }

 private:
  std::string text_;
  std::vector<std::string> outputs_;
  std::vector<std::string> pdf_outputs_;
  bool pdf_ = false;
};

// Runs the script in a staging directory inside `dir`, then moves the
// figures and the script (plots.gp) into `dir`: all of them, or none when
// gnuplot fails or an SVG is missing or truncated (DataError with gnuplot's
// own messages).
void run_gnuplot(const GnuplotScript& script, const std::filesystem::path& dir,
                 const std::filesystem::path& gnuplot);

// The <svg> element of a gnuplot SVG file without the XML prolog, ready to
// sit inside HTML, with every id (gnuplot_canvas, the point symbols gpPt0...)
// and every reference to one (href='#id', url(#id)) prefixed by `id_prefix`:
// gnuplot gives every figure the same ids, and an HTML page with several
// figures must not repeat one.
std::string inline_svg(const std::string& svg, const std::string& id_prefix);

// Quotes a string for a gnuplot script ("..." with \ and " escaped).
std::string gnuplot_quote(const std::string& s);

}  // namespace hapticlab::analysis

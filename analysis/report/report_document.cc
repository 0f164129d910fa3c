// The report's document model rendered twice: self-contained HTML and Markdown.
#include "analysis/study/headline_format.h"
#include "analysis/report/report_parts.h"

#include <algorithm>
#include <functional>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include "analysis/report/box_stats.h"
#include "analysis/report/gnuplot.h"
#include "core/common/utc_time.h"
#include "core/settings/settings_json.h"
#include "analysis/stats/data_error.h"
#include "analysis/stats/sign_flip.h"
#include "core/common/build_info.h"
#include "core/common/output_file.h"

namespace hapticlab::analysis::report_parts {

std::string num(double v, const char* format) {
  if (!std::isfinite(v)) return "N/A";
  char buf[48];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

// File-name-safe form of a participant code or task name.
std::string slug(const std::string& s) {
  std::string out;
  for (char c : s) out += std::isalnum(static_cast<unsigned char>(c)) || c == '-' ? c : '_';
  return out.empty() ? "_" : out;
}

std::string html_escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string md_escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '|' || c == '*' || c == '_') out += '\\';
    out += c;
  }
  return out;
}

std::string read_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw DataError("cannot read '" + path.string() + "'");
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void write_file(const std::filesystem::path& path, const std::string& text) {
  try {
    write_file_atomically(path, text);
  } catch (const OutputFileError& e) {
    throw DataError(std::string("cannot write the report: ") + e.what());
  }
}

std::string render_html(const std::string& title, const std::vector<Section>& sections,
                        const std::filesystem::path& dir) {
  std::ostringstream h;
  h << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>" << html_escape(title)
    << "</title>\n<style>\n"
       "body{font-family:Helvetica,Arial,sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;color:#222}\n"
       "table{border-collapse:collapse;margin:0.5em 0 0.3em}th,td{border:1px solid #bbb;padding:3px 8px;"
       "text-align:left}th{background:#eee}td.b{font-weight:bold}\n"
       "p.note{font-size:0.9em;color:#555;margin-top:0}figure{display:block;margin:1em 0}"
       "figcaption{font-size:0.9em;color:#444}\n"
       "summary{cursor:pointer;font-weight:bold}\n"
       // Figures span the text column, as in a journal; the SVG scales (its viewBox keeps the proportions).
       "figure svg{display:block;width:100%;height:auto}\n</style></head><body>\n";
  h << "<h1>" << html_escape(title) << "</h1>\n";
  h << "<nav><h2 id=\"contents\">Contents</h2><ol>\n";
  for (std::size_t i = 0; i < sections.size(); ++i)
    h << "<li><a href=\"#section-" << i + 1 << "\">" << html_escape(sections[i].title) << "</a></li>\n";
  h << "</ol></nav>\n";
  int figure_number = 0;
  std::size_t section_number = 0;
  for (const Section& s : sections) {
    h << "<h2 id=\"section-" << ++section_number << "\">" << html_escape(s.title) << "</h2>\n";
    if (!s.intro.empty()) h << "<p>" << html_escape(s.intro) << "</p>\n";
    for (const Table& t : s.tables) {
      if (!t.title.empty()) h << "<h3>" << html_escape(t.title) << "</h3>\n";
      h << "<table><tr>";
      for (const auto& c : t.header) h << "<th>" << html_escape(c) << "</th>";
      h << "</tr>\n";
      for (const auto& row : t.rows) {
        h << "<tr>";
        for (const auto& c : row) h << (c.bold ? "<td class=\"b\">" : "<td>") << html_escape(c.text) << "</td>";
        h << "</tr>\n";
      }
      h << "</table>\n";
      if (!t.note.empty()) h << "<p class=\"note\">" << html_escape(t.note) << "</p>\n";
    }
    // Figures of one kind fold away together: a study gives dozens.
    if (!s.figures.empty())
      h << "<details><summary>" << s.figures.size() << (s.figures.size() == 1 ? " figure" : " figures")
        << "</summary>\n";
    for (const Figure& f : s.figures) {
      ++figure_number;
      h << "<figure>" << inline_svg(read_file(dir / f.file), "fig" + std::to_string(figure_number) + "_") << "<figcaption>" << html_escape(f.caption)
        << "</figcaption></figure>\n";
    }
    if (!s.figures.empty()) h << "</details>\n";
  }
  h << "</body></html>\n";
  return h.str();
}

std::string render_markdown(const std::string& title, const std::vector<Section>& sections) {
  std::ostringstream m;
  m << "# " << title << "\n\n";
  for (const Section& s : sections) {
    m << "## " << s.title << "\n\n";
    if (!s.intro.empty()) m << s.intro << "\n\n";
    for (const Table& t : s.tables) {
      if (!t.title.empty()) m << "### " << t.title << "\n\n";
      m << "|";
      for (const auto& c : t.header) m << " " << md_escape(c) << " |";
      m << "\n|";
      for (std::size_t i = 0; i < t.header.size(); ++i) m << "---|";
      m << "\n";
      for (const auto& row : t.rows) {
        m << "|";
        for (const auto& c : row) m << " " << (c.bold ? "**" + md_escape(c.text) + "**" : md_escape(c.text)) << " |";
        m << "\n";
      }
      m << "\n";
      if (!t.note.empty()) m << "*" << t.note << "*\n\n";
    }
    for (const Figure& f : s.figures) m << "![" << f.caption << "](" << f.file << ")\n\n*" << f.caption << "*\n\n";
  }
  return m.str();
}

}  // namespace hapticlab::analysis::report_parts

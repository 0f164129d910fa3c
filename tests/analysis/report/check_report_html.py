#!/usr/bin/python3
"""Renders a HapticLab report.html in headless Chromium and checks what a
reader would see: no id used twice, no SVG text drawn outside its figure
(clipped), every figure as wide as the page's text. Writes screenshots.

usage: check_report_html.py REPORT_HTML SCREENSHOT_DIR
exit 0: all checks passed; 1: a check failed (each failure printed);
77: Chromium, chromedriver or python3-selenium is missing (a skip).
"""
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "testing"))
import headless_chromium  # noqa: E402


def main():
    if len(sys.argv) != 3:
        print(__doc__, file=sys.stderr)
        return 2
    html, shots = os.path.abspath(sys.argv[1]), sys.argv[2]
    driver = headless_chromium.start(extra=("--hide-scrollbars",))
    if driver is None:
        return 77
    failures = []
    try:
        driver.get("file://" + html)
        # Every <details> open, so collapsed figures are laid out and measured.
        driver.execute_script("document.querySelectorAll('details').forEach(d => d.open = true);")
        ids = driver.execute_script("""
            const seen = {};
            document.querySelectorAll('[id]').forEach(e => { seen[e.id] = (seen[e.id] || 0) + 1; });
            return Object.entries(seen).filter(([k, v]) => v > 1);""")
        for name, count in ids:
            failures.append(f"id '{name}' is used {count} times")
        # Text outside its SVG's box is cut off by the browser (overflow hidden):
        # compare the rendered boxes, which include every transform.
        clipped = driver.execute_script("""
            const out = [];
            const svgs = document.querySelectorAll('svg');
            svgs.forEach((svg, i) => {
              const s = svg.getBoundingClientRect();
              svg.querySelectorAll('text').forEach(t => {
                if (!t.textContent.trim()) return;
                const r = t.getBoundingClientRect();
                const tol = 1.0;
                if (r.left < s.left - tol || r.right > s.right + tol || r.top < s.top - tol ||
                    r.bottom > s.bottom + tol) {
                  out.push(`figure ${i + 1} (${svg.id}): text '${t.textContent.trim()}' at ` +
                           `[${r.left.toFixed(0)},${r.top.toFixed(0)} - ${r.right.toFixed(0)},${r.bottom.toFixed(0)}]` +
                           ` outside [${s.left.toFixed(0)},${s.top.toFixed(0)} - ${s.right.toFixed(0)},${s.bottom.toFixed(0)}]`);
                }
              });
            });
            return [svgs.length, out];""")
        svg_count, outside = clipped
        failures.extend(outside)
        if svg_count == 0:
            failures.append("the report has no SVG figure")
        # A figure as wide as the text column (journal figures span the column).
        narrow = driver.execute_script("""
            const body = document.body.getBoundingClientRect().width;
            const cs = getComputedStyle(document.body);
            const column = body - parseFloat(cs.paddingLeft) - parseFloat(cs.paddingRight);
            const out = [];
            document.querySelectorAll('figure svg').forEach((svg, i) => {
              const w = svg.getBoundingClientRect().width;
              if (w < 0.9 * column) out.push(`figure ${i + 1} is ${w.toFixed(0)} px wide, the column ${column.toFixed(0)} px`);
            });
            return out;""")
        failures.extend(narrow)
        os.makedirs(shots, exist_ok=True)
        driver.save_screenshot(os.path.join(shots, "report_top.png"))
        first_figure = driver.find_elements("css selector", "figure")
        if first_figure:
            driver.execute_script("arguments[0].scrollIntoView(true);", first_figure[0])
            driver.save_screenshot(os.path.join(shots, "report_figure.png"))
    finally:
        driver.quit()
    for f in failures:
        print("FAIL:", f)
    print(f"{svg_count} figures checked, {len(failures)} problems")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())

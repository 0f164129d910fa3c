#!/usr/bin/env python3
"""The length rule's checker (scripts/check_lengths.py) on small trees made
here: it names a file over 600 lines, a function over 80 lines and an app/
function over 60 by file, line and length; honours `// long-function:` and
LENGTHS_ALLOWED (an entry may not grow, and one no longer needed must go);
finds functions past the things that fool a brace counter (braces in
strings, raw strings, comments, character literals, an #else branch,
brace-initialised members, tables); and the repository itself keeps the rule.

Usage: check_lengths_test.py SOURCE_DIR WORK_DIR
"""
import sys

from checker_harness import Harness

h = Harness("check_lengths.py")
source_dir, check, run = h.source_dir, h.check, h.run
failures = h.failures


def tree(name, files):
    return h.tree(name, files)


def function(name, body_lines, head="int"):
    """A function of body_lines + 3 lines (its signature and brace, the body, a return, its closing brace)."""
    return f"{head} {name}(int x) {{\n" + "  x += 1;\n" * body_lines + "  return x;\n}\n"


# Lengths just at the limits pass: 80 lines in planning/, 60 in app/, a
# 600-line file; tests are not checked.
status, out = run(tree("good", {
    "planning/a.cc": "namespace p {\n" + function("at_limit", 77) + "}\n",
    "app/plan/b.cc": function("at_app_limit", 57),
    "db/c.cc": "// x\n" * 600,
    "tests/t.cc": function("long_test", 300),
}))
check(status == 0, f"a tree within the limits failed ({status}): {out}")
check("keep the length rule" in out, f"no summary: {out}")

# Each fault, named by file, line and length.
status, out = run(tree("bad", {
    "db/long_file.cc": "// x\n" * 601,
    "planning/f.cc": "// the first line\n" + function("too_long", 78),
    "app/study/g.cc": "\n\n" + function("too_long_for_app", 58),
}))
check(status == 1, f"faults not refused ({status}): {out}")
check("db/long_file.cc:1: the file is 601 lines, over the limit of 600" in out, f"long file not named: {out}")
check("planning/f.cc:2: function too_long is 81 lines, over the limit of 80" in out, f"long function not named: {out}")
check("app/study/g.cc:3: function too_long_for_app is 61 lines, over the limit of 60" in out,
      f"app function not named: {out}")

# The marker is honoured in the comment just above and on the first line;
# a marker without a reason, or separated from the function, is not.
status, out = run(tree("marker", {
    "core/a.cc": "// Long on purpose.\n// long-function: every exit in one place\n" + function("marked", 100) +
                 function("marked_on_line", 100).replace("{\n", "{  // long-function: a table\n", 1) +
                 "// long-function:\n" + function("no_reason", 100) +
                 "// long-function: far away\n\n" + function("not_adjacent", 100),
    "core/big.cc": "// long-file: a generated table\n" + "// x\n" * 700,
}))
check(status == 1, f"marker tree: expected a refusal ({status}): {out}")
check("marked is" not in out and "marked_on_line" not in out, f"a marked function was refused: {out}")
check("function no_reason is 103 lines" in out, f"a marker without a reason was honoured: {out}")
check("function not_adjacent is 103 lines" in out, f"a marker apart from its function was honoured: {out}")
check("core/big.cc" not in out, f"the long-file marker was not honoured: {out}")

# The allow-list: an entry at or above the length passes (a note asks to
# lower one above it); a grown unit, an entry no longer needed and a
# malformed line are refused.
allowed = tree("allowed", {
    "LENGTHS_ALLOWED": "# debt\ncore/a.cc:listed 93\ncore/a.cc:lowered 120\ncore/a.cc:grown 85\n"
                       "core/a.cc:gone 90\ncore/a.cc:short 90\ncore/b.cc 650\nnonsense\n",
    "core/a.cc": function("listed", 90) + function("lowered", 90) + function("grown", 90) + function("short", 10),
    "core/b.cc": "// x\n" * 640,
})
status, out = run(allowed)
check(status == 1, f"allow-list tree: expected a refusal ({status}): {out}")
check("listed" not in out, f"an allowed function was refused: {out}")
check("core/a.cc:" in out and "function lowered is 93 lines now; lower LENGTHS_ALLOWED:3 to 93" in out,
      f"no note to lower an entry: {out}")
check("function grown is 93 lines, more than the 85 that LENGTHS_ALLOWED:4 allows" in out, f"growth allowed: {out}")
check("LENGTHS_ALLOWED:5: core/a.cc:gone is no longer over its limit" in out, f"stale entry kept: {out}")
check("LENGTHS_ALLOWED:6: core/a.cc:short is no longer over its limit" in out, f"needless entry kept: {out}")
check("core/b.cc:1: the file is 640 lines now; lower LENGTHS_ALLOWED:7 to 640" in out, f"allowed file: {out}")
check("LENGTHS_ALLOWED:8: \"nonsense\" is not" in out, f"malformed entry accepted: {out}")

# What fools a brace counter: braces in strings, raw strings, comments and
# character literals, a dropped #else branch, digit separators, members
# initialised with braces, a table, a class with inline methods, extern "C".
tricky = (
    '#include <string>\n'
    'namespace n {\n'
    'const int kTable[] = {\n' + "  1, 2,\n" * 120 + '};\n'
    'struct S {\n'
    '  S(int a) : a_{a}, b_{a, 2}, c_(a) {\n' + "    a_ += 1;\n" * 81 + '  }\n'
    '  int a_; int b_[2]; int c_;\n'
    '  int inline_method() const { return a_; }\n'
    '};\n'
    'extern "C" {\n'
    'int c_api(int x) {\n'
    '  const char* s = "}}}{";\n'
    '  const char* r = R"js(function() { if (x) { )js";\n'
    "  char c = '{';\n"
    '  /* } */ // }\n'
    '#if defined(A)\n'
    '  if (x) {\n'
    '#else\n'
    '  if (!x) {\n'
    '#endif\n'
    "    x = 1'000'000;\n"
    '  }\n' + "  x += 1;\n" * 80 + '  return x + (s != r) + c;\n'
    '}\n'
    '}\n'
    '}  // namespace n\n'
)
status, out = run(tree("tricky", {"core/t.cc": tricky}))
check(status == 1, f"tricky tree: expected two refusals ({status}): {out}")
check("function S is 83 lines" in out, f"constructor with brace-initialised members not measured: {out}")
check("function c_api is 94 lines" in out, f"function with braces in literals not measured: {out}")
check("kTable" not in out and "inline_method" not in out, f"a table or short method refused: {out}")
check(out.count("over the limit") == 2, f"expected exactly two refusals: {out}")

# An unbalanced file is a named refusal, not a silent pass.
status, out = run(tree("unbalanced", {"core/u.cc": "int f() {\n  return 0;\n"}))
check(status == 1 and "core/u.cc: cannot find its functions" in out, f"unbalanced file passed: {out}")

# The repository keeps the rule.
status, out = run(source_dir)
check(status == 0, f"the repository breaks the length rule:\n{out}")

for f in failures:
    print("FAIL:", f)
print(f"check_lengths_test: {len(failures)} failure(s)")
sys.exit(1 if failures else 0)

#!/usr/bin/env python3
"""Checks the length rule of HapticLab's C and C++ sources (issue 37).

Usage: scripts/check_lengths.py [SOURCE_DIR]   (default: the repository root)

The rule (docs/architecture.md, "How long a unit may be"):
  - no source file over 600 lines;
  - no function over 80 lines, and none in app/ over 60;
  - tests/ are not checked; a function (or a generated table's file) may be
    longer when a comment says why: `// long-function: <why>` in the comment
    just above the function or on its first line (`// long-file: <why>` in a
    file's first 20 lines for a file);
  - what was already longer when the rule came is listed, each entry with its
    length then, in LENGTHS_ALLOWED at the top of the tree: an entry may not
    grow, and one that is no longer needed must go (the list only shrinks).

Prints each unit against the rule as FILE:LINE with its length and exits 1,
or says how many files and functions it checked and exits 0.

How it finds functions (a heuristic that is right on this code base, and
tested on small trees by tests/layers/check_lengths_test.py): comments,
string and character literals (raw strings too) and preprocessor lines are
blanked out, keeping only the first branch of an #if/#else; then braces are
matched. A `{` met in a namespace, a class or an `extern "C"` block, or at
file level, opens a function body when the text before it (since the last
`;`, `{` or `}` of that scope) ends with `)`, possibly followed by
qualifiers (const, noexcept, override, final, mutable, a trailing return
type) or a constructor's member initialisers. Braces inside a function
(blocks, lambdas, local classes) belong to that function. Other braces at
those scopes (tables, initialisers, enums) are data, not functions. A
function's length is the count of lines from its opening to its closing
brace, both included.
"""
import os
import re
import sys

SOURCE_SUFFIXES = (".h", ".hpp", ".c", ".cc", ".cpp")
UNCHECKED = ("tests/", "build", ".git/")
MAX_FILE_LINES = 600
MAX_FUNCTION_LINES = 80
MAX_APP_FUNCTION_LINES = 60
ALLOW_LIST = "LENGTHS_ALLOWED"
FUNCTION_MARKER = re.compile(r"//\s*long-function:\s*\S")
FILE_MARKER = re.compile(r"//\s*long-file:\s*\S")


def blank(text):
    """`text` with comments, literals and preprocessor lines replaced by
    spaces (newlines kept, so offsets and line numbers stay)."""
    out = list(text)
    n = len(text)
    i = 0

    def wipe(a, b):
        for k in range(a, min(b, n)):
            if out[k] != "\n":
                out[k] = " "

    at_line_start = True
    skip_depth = 0  # > 0: inside an #else/#elif branch being dropped
    if_depth = 0
    while i < n:
        c = text[i]
        if at_line_start:
            j = i
            while j < n and text[j] in " \t":
                j += 1
            if j < n and text[j] == "#":
                # A directive, with its continuation lines.
                end = j
                while True:
                    e = text.find("\n", end)
                    if e < 0:
                        e = n
                    if e > 0 and text[e - 1] == "\\" and e < n:
                        end = e + 1
                        continue
                    break
                directive = re.match(r"#\s*(\w+)", text[j:e])
                word = directive.group(1) if directive else ""
                if word in ("if", "ifdef", "ifndef"):
                    if_depth += 1
                    if skip_depth:
                        skip_depth += 1
                elif word in ("else", "elif"):
                    if not skip_depth:
                        skip_depth = 1
                elif word == "endif":
                    if_depth -= 1
                    if skip_depth:
                        skip_depth -= 1
                wipe(i, e)
                i = e
                continue
            if skip_depth:
                e = text.find("\n", i)
                e = n if e < 0 else e
                wipe(i, e)
                i = e + 1
                continue
            at_line_start = False
        if c == "\n":
            at_line_start = True
            i += 1
        elif text.startswith("//", i):
            e = text.find("\n", i)
            e = n if e < 0 else e
            wipe(i, e)
            i = e
        elif text.startswith("/*", i):
            e = text.find("*/", i + 2)
            e = n if e < 0 else e + 2
            wipe(i, e)
            i = e
        elif c == '"':
            prefix = re.search(r"(\w*)$", text[max(0, i - 4):i]).group(1)
            if prefix in ("R", "u8R", "uR", "UR", "LR"):
                m = re.match(r'"([^()\\ ]{0,16})\(', text[i:])
                if m:
                    close = ")" + m.group(1) + '"'
                    e = text.find(close, i + len(m.group(0)))
                    e = n if e < 0 else e + len(close)
                    wipe(i + 1, e - 1)
                    i = e
                    continue
            j = i + 1
            while j < n and text[j] != '"' and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            wipe(i + 1, j)
            i = j + 1
        elif c == "'":
            if i > 0 and (text[i - 1].isalnum() or text[i - 1] == "_") and i + 1 < n and text[i + 1].isalnum():
                i += 1  # a digit separator: 1'000'000
                continue
            j = i + 1
            while j < n and text[j] != "'" and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            wipe(i + 1, j)
            i = j + 1
        else:
            i += 1
    return "".join(out)


QUALIFIERS = re.compile(r"\)\s*(?:(?:const|volatile|noexcept(?:\s*\([^()]*\))?|override|final|mutable|&&|&|"
                        r"->\s*[\w:<>,\s*&]+?)\s*)*$")
# A constructor's member initialiser list under way: `) : a_(x), b_`.
INIT_LIST = re.compile(r"\)\s*(?:noexcept\s*)?:(?!:)")


def function_name(head):
    """The name of the function whose signature is `head` (best effort)."""
    m = re.search(r"(operator\s*(?:\(\)|[^\s(]+))\s*\(", head)
    if m:
        name_end = m.end(1)
        start = m.start(1)
    else:
        depth = 0
        name_end = None
        for k, ch in enumerate(head):
            if ch == "<":
                depth += 1
            elif ch == ">":
                depth = max(0, depth - 1)
            elif ch == "(" and depth == 0:
                name_end = k
                break
        if name_end is None:
            return "?"
        start = name_end
    m = re.search(r"([~\w:]+(?:<[^()]*>)?)\s*$", head[:name_end] if not m else head[:start] + head[start:name_end])
    name = m.group(1) if m else "?"
    if name in ("", "?") or name.endswith("]"):
        return "<lambda>"
    return name


def functions(code):
    """(name, first line of the signature, opening brace line, closing brace
    line) of each function in blanked `code`, lines counted from 1."""
    found = []
    newlines = [i for i, ch in enumerate(code) if ch == "\n"]

    def line(offset):
        lo, hi = 0, len(newlines)
        while lo < hi:
            mid = (lo + hi) // 2
            if newlines[mid] < offset:
                lo = mid + 1
            else:
                hi = mid
        return lo + 1

    # The open braces: "scope" (namespace, class, extern "C"), "data" (an
    # initialiser), a function (a tuple) or "inner" (a brace in a function).
    stack = []
    head_start = 0
    i, n = 0, len(code)
    while i < n:
        ch = code[i]
        if ch in ";" and (not stack or stack[-1] == "scope"):
            head_start = i + 1
        elif ch == "{":
            if stack and stack[-1] != "scope":
                stack.append(stack[-1] if stack[-1] == "data" else "inner")
                i += 1
                continue
            head = code[head_start:i].strip()
            flat = " ".join(head.split())
            if re.match(r"^(?:inline\s+)?namespace\b", flat) or re.match(r'^extern\s*"\s*"$', flat):
                stack.append("scope")
                head_start = i + 1
            elif INIT_LIST.search(flat) and not QUALIFIERS.search(flat) and re.search(r"[\w>]$", flat):
                # A member initialised with braces: skip to its `}` and go on
                # reading the constructor's head.
                depth, j = 0, i
                while j < n:
                    if code[j] == "{":
                        depth += 1
                    elif code[j] == "}":
                        depth -= 1
                        if depth == 0:
                            break
                    j += 1
                i = j + 1
                continue
            elif QUALIFIERS.search(flat) and not re.match(r"^(?:typedef|using)\b", flat) and "=" not in flat.split("(")[0]:
                name = function_name(flat)
                first = head_start + (len(code[head_start:i]) - len(code[head_start:i].lstrip()))
                stack.append(("function", name, line(first), line(i)))
            elif re.search(r"\b(class|struct|union|enum)\b", flat) and "=" not in flat and "(" not in flat:
                stack.append("scope")
                head_start = i + 1
            elif QUALIFIERS.search(flat):
                # A lambda or call at namespace scope (`auto f = [](...) {`).
                name = function_name(flat)
                first = head_start + (len(code[head_start:i]) - len(code[head_start:i].lstrip()))
                stack.append(("function", name, line(first), line(i)))
            else:
                stack.append("data")
        elif ch == "}":
            if not stack:
                raise ValueError(f"line {line(i)}: a `}}` closes nothing")
            top = stack.pop()
            if isinstance(top, tuple):
                _, name, first, open_line = top
                found.append((name, first, open_line, line(i)))
            if not stack or stack[-1] == "scope":
                head_start = i + 1
        i += 1
    if stack:
        raise ValueError(f"{len(stack)} brace(s) left open at the end")
    return found


def marker_above(lines, first_line, open_line):
    """Whether `// long-function: <why>` is in the comment right above the
    function (contiguous comment lines) or on its signature's lines."""
    for k in range(first_line - 1, open_line):
        if FUNCTION_MARKER.search(lines[k]):
            return True
    k = first_line - 2
    while k >= 0 and lines[k].strip().startswith("//"):
        if FUNCTION_MARKER.search(lines[k]):
            return True
        k -= 1
    return False


def read_allow_list(root):
    """{key: allowed length}: keys are FILE (a file) or FILE:FUNCTION."""
    allowed = {}
    path = os.path.join(root, ALLOW_LIST)
    if not os.path.exists(path):
        return allowed, []
    problems = []
    with open(path, encoding="utf-8") as f:
        for number, text in enumerate(f, 1):
            text = text.split("#", 1)[0].strip()
            if not text:
                continue
            parts = text.split()
            if len(parts) != 2 or not parts[1].isdigit():
                problems.append(f"{ALLOW_LIST}:{number}: \"{text}\" is not `FILE[:FUNCTION] LINES`")
                continue
            allowed[parts[0]] = (int(parts[1]), number)
    return allowed, problems


def source_files(root):
    for directory, subdirectories, files in os.walk(root):
        relative_dir = os.path.relpath(directory, root)
        relative_dir = "" if relative_dir == "." else relative_dir + "/"
        subdirectories[:] = sorted(d for d in subdirectories if not (relative_dir + d + "/").startswith(UNCHECKED))
        for name in sorted(files):
            if name.endswith(SOURCE_SUFFIXES):
                yield relative_dir + name


def main():
    root = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), ".."))
    allowed, problems = read_allow_list(root)
    used = set()
    notes = []
    file_count = function_count = 0

    def judge(key, where, length, limit, what):
        if length <= limit:
            return
        if key in allowed:
            used.add(key)
            ceiling, number = allowed[key]
            if length > ceiling:
                problems.append(f"{where}: {what} is {length} lines, more than the {ceiling} that "
                                f"{ALLOW_LIST}:{number} allows (limit {limit}); shorten it")
            elif length < ceiling:
                notes.append(f"{where}: {what} is {length} lines now; lower {ALLOW_LIST}:{number} to {length}")
            return
        marker = "`// long-file: <why>` in its first 20 lines" if what == "the file" else \
            "a `// long-function: <why>` comment above it"
        problems.append(f"{where}: {what} is {length} lines, over the limit of {limit}; "
                        f"split it, or say why it must be long in {marker}")

    for path in source_files(root):
        with open(os.path.join(root, path), encoding="utf-8", errors="replace") as f:
            text = f.read()
        lines = text.split("\n")
        line_count = len(lines) - (1 if text.endswith("\n") else 0)
        file_count += 1
        if not any(FILE_MARKER.search(l) for l in lines[:20]):
            judge(path, f"{path}:1", line_count, MAX_FILE_LINES, "the file")
        try:
            found = functions(blank(text))
        except ValueError as e:
            problems.append(f"{path}: cannot find its functions ({e})")
            continue
        limit = MAX_APP_FUNCTION_LINES if path.startswith("app/") else MAX_FUNCTION_LINES
        for name, first, open_line, close_line in found:
            function_count += 1
            length = close_line - open_line + 1
            if length > limit and marker_above(lines, first, open_line):
                continue
            judge(f"{path}:{name}", f"{path}:{first}", length, limit, f"function {name}")
    for key, (ceiling, number) in sorted(allowed.items(), key=lambda kv: kv[1][1]):
        if key not in used:
            problems.append(f"{ALLOW_LIST}:{number}: {key} is no longer over its limit (or no longer exists); "
                            "remove the entry")
    for note in notes:
        print(note)
    for p in problems:
        print(p)
    if problems:
        print(f"check_lengths: {len(problems)} problem(s) with the length rule (docs/architecture.md)")
        return 1
    print(f"check_lengths: {file_count} files and {function_count} functions keep the length rule "
          f"({len(allowed)} allowed in {ALLOW_LIST})")
    return 0


if __name__ == "__main__":
    sys.exit(main())

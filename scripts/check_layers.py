#!/usr/bin/env python3
"""Checks every #include "..." of HapticLab's sources against LAYERS.

Usage: scripts/check_layers.py [SOURCE_DIR]   (default: the repository root)

Prints each include against the rule as FILE:LINE and exits 1, or says how
many includes it checked and exits 0. The rule is in LAYERS; why it is what
it is, in docs/architecture.md.
"""
import os
import re
import sys

SOURCE_SUFFIXES = (".h", ".hpp", ".c", ".cc", ".cpp")
INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"')
# Folders whose files are not checked: tests drive any part; build output.
UNCHECKED = ("tests/", "build", ".git/")
EXAMPLES = "examples/"


def read_layers(path):
    layers = []
    with open(path, encoding="utf-8") as f:
        for number, line in enumerate(f, 1):
            line = line.split("#", 1)[0].strip()
            if line:
                layers.append((number, line.split()))
    level = {}
    for index, (number, parts) in enumerate(layers):
        for part in parts:
            if part in level:
                sys.exit(f"{path}:{number}: part {part} is listed twice")
            level[part] = index
    return level


def part_of(path, level):
    """The longest LAYERS entry that `path` starts with, or None."""
    best = None
    for part in level:
        if (path == part or path.startswith(part + "/")) and (best is None or len(part) > len(best)):
            best = part
    return best


def include_target(include, including_file):
    """The repository path an include names: "hapticlab/X.h" is the public
    C header; a name without a folder is beside the including file."""
    if include.startswith("hapticlab/"):
        return "core/capi/" + include
    if "/" not in include:
        return os.path.join(os.path.dirname(including_file), include)
    return include


def main():
    root = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), ".."))
    level = read_layers(os.path.join(root, "LAYERS"))
    problems, checked = [], 0
    for directory, subdirectories, files in os.walk(root):
        relative_dir = os.path.relpath(directory, root)
        relative_dir = "" if relative_dir == "." else relative_dir + "/"
        subdirectories[:] = sorted(d for d in subdirectories if not (relative_dir + d + "/").startswith(UNCHECKED))
        for name in sorted(files):
            if not name.endswith(SOURCE_SUFFIXES):
                continue
            path = relative_dir + name
            own = part_of(path, level)
            in_examples = path.startswith(EXAMPLES)
            if own is None and not in_examples:
                # A new folder must take its place in the rule before its
                # includes can be judged.
                problems.append(f"{path}: is in no part of LAYERS; add its folder to the line of its layer")
                continue
            with open(os.path.join(root, path), encoding="utf-8", errors="replace") as f:
                for line_number, line in enumerate(f, 1):
                    m = INCLUDE.match(line)
                    if not m:
                        continue
                    target = include_target(m.group(1), path)
                    theirs = part_of(target, level)
                    if theirs is None:
                        continue  # not a HapticLab header (a system or generated one)
                    checked += 1
                    if in_examples:
                        if theirs != "core/capi/hapticlab":
                            problems.append(f"{path}:{line_number}: includes \"{m.group(1)}\" ({theirs}); "
                                            "an example may include the public C headers (hapticlab/*.h) only")
                        continue
                    if theirs == own:
                        continue
                    if level[theirs] < level[own]:
                        continue
                    why = ("a sibling on the same line" if level[theirs] == level[own]
                           else f"a higher layer (line {level[theirs] + 1} of the layers, above {own}'s {level[own] + 1})")
                    problems.append(f"{path}:{line_number}: includes \"{m.group(1)}\" of {theirs}, "
                                    f"{why}; {own} may include only parts listed before it in LAYERS")
    for p in problems:
        print(p)
    if problems:
        print(f"check_layers: {len(problems)} problem(s) with the dependency rule (LAYERS, docs/architecture.md)")
        return 1
    print(f"check_layers: {checked} includes follow the dependency rule (LAYERS)")
    return 0


if __name__ == "__main__":
    sys.exit(main())

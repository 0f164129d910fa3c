"""What the tests of the repository's rule checkers (scripts/check_layers.py,
scripts/check_lengths.py) share: command-line arguments, a list of
failures, running a checker on a tree, and making small trees to run it on.

Usage from a test: `h = Harness("check_lengths.py")`, then h.check(...),
h.run(root), h.tree(name, files, copy=[...]), and finally h.finish(name).
"""
import os
import shutil
import subprocess
import sys


class Harness:
    def __init__(self, checker_name):
        self.source_dir, self.work_dir = sys.argv[1], sys.argv[2]
        self.checker = os.path.join(self.source_dir, "scripts", checker_name)
        self.failures = []

    def check(self, condition, what):
        if not condition:
            self.failures.append(what)

    def run(self, root):
        r = subprocess.run([sys.executable, self.checker, root], capture_output=True, text=True)
        return r.returncode, r.stdout + r.stderr

    def tree(self, name, files, copy=()):
        """A fresh tree WORK_DIR/name holding `files` (path -> text) and the
        repository's files named in `copy` (e.g. LAYERS)."""
        root = os.path.join(self.work_dir, name)
        shutil.rmtree(root, ignore_errors=True)
        os.makedirs(root)
        for path in copy:
            shutil.copy(os.path.join(self.source_dir, path), root)
        for path, text in files.items():
            os.makedirs(os.path.join(root, os.path.dirname(path)) or root, exist_ok=True)
            with open(os.path.join(root, path), "w") as f:
                f.write(text)
        return root

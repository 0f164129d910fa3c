#!/usr/bin/env python3
"""The dependency rule's checker (scripts/check_layers.py) on small trees
made here: it names every include against LAYERS by file and line (a lower
layer including a higher one, siblings, an example including an internal
header, a folder in no part), passes a tree that keeps the rule, and the
repository itself keeps it.

Usage: check_layers_test.py SOURCE_DIR WORK_DIR
"""
import sys

from checker_harness import Harness

h = Harness("check_layers.py")
source_dir, check, run = h.source_dir, h.check, h.run
failures = h.failures


def tree(name, files):
    return h.tree(name, files, copy=["LAYERS"])


# A tree that keeps the rule: downward includes, a same-folder include, the
# public C header by its installed name, a test including anything.
status, out = run(tree("good", {
    "core/common/clock.h": "#pragma once\n",
    "core/loop/haptic_loop.h": '#include "core/common/clock.h"\n#include "virtual_environment.h"\n',
    "core/loop/virtual_environment.h": "#pragma once\n",
    "core/device/plugin_device.h": '#include "hapticlab/device_plugin.h"\n',
    "core/capi/hapticlab/device_plugin.h": "#pragma once\n",
    "app/main.cc": '#include "core/loop/haptic_loop.h"\n#include <vector>\n',
    "tests/core/common/clock_test.cc": '#include "app/main.cc"\n',
    "examples/c_driver/driver.c": '#include "hapticlab/hapticlab.h"\n',
}))
check(status == 0, f"a tree that keeps the rule failed ({status}): {out}")
check("follow the dependency rule" in out, f"no summary: {out}")

# Each kind of fault, named by file and line.
status, out = run(tree("bad", {
    "core/common/clock.h": "#pragma once\n",
    "core/device/sim_device.cc": '// the device\n#include "core/common/clock.h"\n#include "core/loop/clock.h"\n',
    "core/loop/clock.h": "#pragma once\n",
    "core/capi/hapticlab_c.cc": '#include "core/device/sim_device.cc"\n',
    "db/study_db.h": '#include "analysis/stats.h"\n',
    "analysis/stats.h": "#pragma once\n",
    "examples/c_driver/driver.c": '#include "core/engine/engine.h"\n',
    "core/engine/engine.h": "#pragma once\n",
    "core/io/reader.h": '#include "core/common/clock.h"\n',
}))
check(status == 1, f"faults passed ({status}): {out}")
check('core/device/sim_device.cc:3: includes "core/loop/clock.h" of core/loop, a higher layer' in out,
      f"lower including higher not named by line: {out}")
check("core/device/sim_device.cc:2" not in out, f"a downward include was reported: {out}")
check('core/capi/hapticlab_c.cc:1: includes "core/device/sim_device.cc" of core/device, a sibling' in out,
      f"sibling include not named: {out}")
check('db/study_db.h:1: includes "analysis/stats.h" of analysis, a higher layer' in out,
      f"top-level fault not named: {out}")
check("examples/c_driver/driver.c:1: includes \"core/engine/engine.h\" (core/engine); an example may include "
      "the public C headers (hapticlab/*.h) only" in out, f"example fault not named: {out}")
check("core/io/reader.h: is in no part of LAYERS" in out, f"a folder outside the rule not named: {out}")
check("check_layers: 5 problem(s) with the dependency rule" in out, f"wrong count: {out}")

# The repository keeps its own rule.
status, out = run(source_dir)
check(status == 0, f"the repository breaks its rule:\n{out}")

for f in failures:
    print("FAIL:", f)
print("check_layers_test:", "FAILED" if failures else "passed", f"({len(failures)} failure(s))")
sys.exit(1 if failures else 0)

"""A steady tick allocates nothing in compiled code (issue 36's small working set): the kernels work in
buffers made once per configuration (the arena, the IK's and the gaze's workspaces, the frame tail's
table). tracemalloc cannot see numba's allocations, so numba's own counters are read instead, in a
process of its own (they are switched on by NUMBA_NRT_STATS before numba is imported).

What remains per tick is one adapter per array handed from Python to compiled code: each call of the
core's kernel takes two (its op table and its address table), the frame tail five (its table, the
program's frame, stage 1, the frame buffer and the joints). The kernel is called once per segment of
compiled steps, and once more after each trap (a blink's or a weight shift's draws, core/vm.py).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from backend.engine.blocks import BLOCKS, BlockContext
from backend.engine.embodiment import load_embodiment
from backend.engine.frames import PartialFrame

ROOT = Path(__file__).resolve().parents[1]
#: Array adapters per call of the core's kernel, and per tick for the frame tail.
KERNEL_ADAPTERS, TAIL_ADAPTERS = 2, 5
TICKS = 500

SCRIPT = """
import json, sys
from numba.core.runtime import rtsys
from backend.engine import warm_up
from backend.engine.core.program import KERNEL
from backend.engine.embodiment import load_embodiment
from backend.engine.frame_tail import TAIL
from backend.session import EngineSession

KERNEL.wait(120)
TAIL.wait(120)
desk = load_embodiment("nutty_desk")
counts = {}
ticks = int(sys.argv[1])
for name in sys.argv[2:]:
    program = json.loads(open(f"robots/nutty_desk/programs/{name}.json").read())
    engine = EngineSession.create(desk, program=program).engine
    engine.run_ticks(300)
    warm_up.wait(120)  # its thread calls compiled code too (numba counts for the whole process)
    engine.apu.cook.every = 10**9  # only the core's ticks (a timed tick runs the blocks one by one)
    core = engine.apu.core
    traps = []
    for op in core.ops:  # each trap calls the kernel once more
        op.trap = lambda dt, results, own=op.trap: traps.append(dt) or own(dt, results)
    segments = sum(1 for entry in core.plan if entry[0] == "core")
    before = rtsys.get_allocation_stats()
    engine.run_ticks(ticks)
    after = rtsys.get_allocation_stats()
    counts[name] = [after.alloc - before.alloc, after.free - before.free, segments * ticks + len(traps)]
print(json.dumps(counts))
"""


@pytest.mark.parametrize("names", [["breathe-anything", "idle", "interactive"]])
def test_a_steady_tick_allocates_only_its_argument_adapters_in_compiled_code(names):
    env = {**os.environ, "NUMBA_NRT_STATS": "1"}
    done = subprocess.run(
        [sys.executable, "-c", SCRIPT, str(TICKS), *names],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    counts = json.loads(done.stdout.strip().splitlines()[-1])
    for name in names:
        allocated, freed, kernel_calls = counts[name]
        # interactive runs the IK and the gaze every tick: 48 per tick before their workspaces
        expected = KERNEL_ADAPTERS * kernel_calls + TAIL_ADAPTERS * TICKS
        assert allocated == expected, f"{name}: {allocated} compiled allocations in {TICKS} ticks"
        assert freed == allocated, f"{name}: compiled memory not freed ({freed} of {allocated})"
        assert kernel_calls >= TICKS


@pytest.mark.parametrize("kind", ["ik", "gaze"])
def test_a_workspace_too_small_for_its_chain_is_refused_not_overrun(kind):
    """The kernels carve their scratch from the workspace with slices, which stop at its end: one made
    for another chain must raise, never be written past."""
    desk = load_embodiment("nutty_desk")
    cls = BLOCKS[kind]
    block = cls(cls.Params(), BlockContext(embodiment=desk, rate=100.0), "n")
    *args, workspace = block._kernel_args
    block._kernel_args = (*args, np.zeros(workspace.size - 1))
    target = [1.0, 0.2, 0.35]
    with pytest.raises(ValueError):
        if kind == "ik":
            everything = PartialFrame(desk.rest.copy(), np.ones(desk.n_channels, dtype=bool), [])
            block.transform(0.01, everything, {"target": target})
        else:
            block.tick(0.01, {"target": target})

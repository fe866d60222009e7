"""docs/architecture.md's source-block example runs as written (registered by the entry-point line the
page gives, installed as a throwaway distribution), and what the page says about an editor panel is
true of the shipped one: its line count, its two lines in panels/index.ts and where its styles are."""

from __future__ import annotations

import math
import re
import sys
import tomllib
import types
from pathlib import Path

import numpy as np
import pytest

from backend.engine.blocks import block_catalog
from backend.graph.builder import ProgramBuilder
from backend.session import EngineSession
from tests.plugin_dist import installed

ROOT = Path(__file__).resolve().parents[1]
DOC = (ROOT / "docs" / "architecture.md").read_text()
PANELS = ROOT / "frontend" / "node_editor" / "panels"


def example(name: str) -> str:
    """The fenced code block that follows `<!-- example: name -->` in the page."""
    m = re.search(rf"<!-- example: {name} -->\s*```\w+\n(.*?)```", DOC, re.S)
    assert m, f"docs/architecture.md has no example '{name}'"
    return m.group(1)


@pytest.fixture()
def heartbeat(tmp_path):
    """The source example as the module the page names, registered by the page's entry-point line."""
    module = "backend.engine.blocks.heartbeat"
    mod = types.ModuleType(module)
    sys.modules[module] = mod  # dataclasses and pydantic look their module up
    try:
        exec(compile(example("source"), "docs/architecture.md:source", "exec"), mod.__dict__)
        entry_points = tomllib.loads(example("source-entry"))["project"]["entry-points"]
        with installed(tmp_path / "source", "docs-source", entry_points):
            yield mod
    finally:
        sys.modules.pop(module, None)


def expected_pulse(beat: float) -> float:
    def bump(u: float, width: float = 0.15) -> float:
        return 0.5 - 0.5 * math.cos(2 * math.pi * u / width) if 0.0 <= u < width else 0.0

    return bump(beat) + 0.6 * bump(beat - 0.25)


def test_source_example_registers_as_a_source_with_a_drivable_rate(heartbeat):
    entry = next(e for e in block_catalog() if e["type"] == "heartbeat")
    assert entry["category"] == "sources" and entry["role"] == "source"
    assert set(entry["inputs"]) == {"bpm"} and entry["inputs"]["bpm"]["type"] == "float"
    assert set(entry["outputs"]) == {"out"} and entry["outputs"]["out"]["type"] == "frame"


def test_source_example_beats_on_its_dofs(desk, heartbeat):
    b = ProgramBuilder("heartbeat")
    beat = b.node("heartbeat", "heart", dofs=["neck_pitch"], depth=0.04, bpm=90.0)
    b.chain(beat, b.output())
    session = EngineSession.create(desk, rate=100, program=b.build())
    frames = list(session.run_headless(200))
    session.engine.close()
    i = desk.channel_index["neck_pitch"]
    program = np.array([f.program[i] for f in frames])
    beats = (np.arange(1, 201) * 0.01 * 90.0 / 60.0) % 1.0
    expected = desk.rest[i] + 0.04 * np.array([expected_pulse(u) for u in beats])
    assert np.allclose(program, expected, atol=1e-9)
    assert program.max() > desk.rest[i] + 0.03  # it does beat


def test_source_example_rate_follows_a_wired_signal_within_its_bounds(desk, heartbeat):
    b = ProgramBuilder("heartbeat-driven")
    beat = b.node("heartbeat", "heart", dofs=["neck_pitch"], depth=0.04, bpm=60.0)
    rate = b.node("math", "rate", op="add", a=500.0, b=0.0)  # beyond bpm's le=200: clamped
    b.chain(beat, b.output())
    b.connect(rate, beat, "value", "bpm")
    session = EngineSession.create(desk, rate=100, program=b.build())
    frames = list(session.run_headless(7))
    session.engine.close()
    i = desk.channel_index["neck_pitch"]
    beat_now = (7 * 0.01 * 200.0 / 60.0) % 1.0
    assert frames[-1].program[i] == pytest.approx(desk.rest[i] + 0.04 * expected_pulse(beat_now), abs=1e-9)


def test_panel_step_counts_are_the_shipped_panels():
    panel = (PANELS / "ProgramInfoPanel.tsx").read_text()
    n = len(panel.splitlines())
    assert (
        f"one {n}-line file" in DOC
        and f"`frontend/node_editor/panels/ProgramInfoPanel.tsx` ({n} lines)" in DOC
    )
    index = (PANELS / "index.ts").read_text()
    assert index.count(example("panel-import").strip()) == 1


def test_panel_styles_are_in_the_editors_stylesheet():
    styles = ROOT / "frontend" / "node_editor" / "styles.css"
    assert "`frontend/node_editor/styles.css`" in DOC
    text = styles.read_text()
    for rule in example("panel-styles").strip().splitlines():
        assert rule in text, rule
    assert 'import "./styles.css"' in (ROOT / "frontend" / "node_editor" / "main.tsx").read_text()


def test_the_regeneration_command_is_the_one_package_json_defines():
    package = (ROOT / "frontend" / "package.json").read_text()
    assert '"gen:types": "node scripts/gen-types.mjs"' in package
    script = (ROOT / "frontend" / "scripts" / "gen-types.mjs").read_text()
    assert '"schema", out' in script  # gen:types runs `nutty schema` into generated/ (blocks.json among them)
    assert "`npm run gen:types` in `frontend/`" in DOC

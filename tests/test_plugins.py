"""Another package adds a block, a command (with its AI tool), a driver and an importer by its own entry
points alone, with no edit to this project: the package is written into a folder with its
`.dist-info`, put on sys.path, and the registries read their groups again (tests/plugin_dist.py).

A broken entry point is a PluginError naming it and its distribution, and leaves the registry as it was.
"""

from __future__ import annotations

import argparse
import asyncio
from pathlib import Path

import httpx
import mcp
import numpy as np
import pytest
from fastapi.testclient import TestClient

from backend import control, drivers, importers
from backend.api import create_app
from backend.engine import blocks
from backend.engine.blocks import BLOCKS, block_catalog
from backend.graph.builder import ProgramBuilder
from backend.plugins import PluginError
from backend.session import EngineSession
from backend.tools import build_tools
from tests.plugin_dist import installed

INTERACTIVE = Path(__file__).resolve().parents[1] / "robots" / "nutty_desk" / "programs" / "interactive.json"

# One module per kind, as a plugin package would lay them out.
FILES = {
    "nutty_gestures/__init__.py": '"""Gestures for Nutty: a plugin package written by tests/test_plugins.py."""\n',
    "nutty_gestures/blocks.py": '''
from pydantic import Field

from backend.engine.blocks.base import BlockParams, Operator
from backend.engine.frames import PartialFrame


class NudgeParams(BlockParams):
    dof: str = Field("head_yaw", description="the DoF to nudge")
    amount: float = Field(0.1, ge=-0.5, le=0.5, description="added to it (rad)")


class Nudge(Operator):
    """Adds `amount` to one DoF (a block of a plugin package)."""

    type_name = "nudge"
    title = "Nudge"
    Params = NudgeParams

    def configure(self):
        self.index = self.emb.channel_index[self.params.dof]

    def transform(self, dt, frame, inputs):
        values, mask = frame.values.copy(), frame.mask.copy()
        values[self.index] += self.params.amount
        mask[self.index] = True
        return {"out": PartialFrame(values, mask, frame.events)}
''',
    "nutty_gestures/commands.py": '''
from typing import Literal

from pydantic import Field

from backend.control.ai import AiTool
from backend.control.base import BaseCommand, Target
from backend.control.targets import set_inputs


class Wave(BaseCommand):
    """Liven the robot up: its `arousal` input to `energy` (a command of a plugin package)."""

    acts_on = Target(role="input", what="arousal input")
    ai_tool = AiTool(
        "wave_hello",
        "Wave hello, as lively as `energy` says.",
        available=lambda live: live.input("arousal") is not None,
    )
    type: Literal["wave"] = "wave"
    energy: float = Field(0.5, ge=0.0, le=1.0, description="how lively (0..1)")

    def run(self, ctx):
        return set_inputs(ctx.session, {"arousal": self.energy})
''',
    "nutty_gestures/drivers.py": """
from backend.drivers.registry import DriverOption
from backend.engine.runtime import Sink

SEEN = []


class Tally(Sink):
    option = DriverOption("tally", metavar="N", parse=int, help="note the time of every N-th frame")

    def __init__(self, every):
        super().__init__("tally", max_queue=64, decimate=every)

    @classmethod
    def from_option(cls, embodiment, every):
        return cls(every)

    def consume(self, frame):
        SEEN.append(frame.t)
""",
    "nutty_gestures/importers.py": '''
import numpy as np

from backend.importers import SourceChannel
from backend.importers.sources import Importer


class TsvImporter(Importer):
    """Tab-separated keys: a `time` column, then one column per DoF."""

    name = "tsv"
    label = "TSV"
    suffixes = (".tsv",)
    options = frozenset({"interp"})
    axes = False

    @classmethod
    def read(cls, path, options):
        rows = [line.split("\\t") for line in path.read_text().splitlines() if line.strip()]
        header, body = rows[0], rows[1:]
        times = np.array([float(r[0]) for r in body])
        channels = [
            SourceChannel(name, "scalar", times, np.array([float(r[c]) for r in body]), "LINEAR", unit="row")
            for c, name in enumerate(header[1:], 1)
        ]
        return channels, {"rows": len(body)}, []
''',
}

ENTRY_POINTS = {
    "nutty.blocks": {"nudge": "nutty_gestures.blocks:Nudge"},
    "nutty.commands": {"wave": "nutty_gestures.commands:Wave"},
    "nutty.drivers": {"tally": "nutty_gestures.drivers:Tally"},
    "nutty.importers": {"tsv": "nutty_gestures.importers:TsvImporter"},
}


@pytest.fixture()
def plugin(tmp_path):
    with installed(tmp_path / "site", "nutty-gestures", ENTRY_POINTS, FILES) as root:
        yield root
    assert "nudge" not in BLOCKS and control.REGISTRY.get("wave") is None  # gone with the package
    assert "tally" not in drivers.DRIVER_OPTIONS and ".tsv" not in importers.FORMATS


@pytest.fixture()
def session(desk):
    s = EngineSession.create(desk, rate=100, program_text=INTERACTIVE.read_text())
    yield s
    s.engine.close()


def program_output(desk, with_nudge: bool) -> float:
    b = ProgramBuilder("nudged")
    chain = [b.node("pose", "rest", posture="neutral")]
    if with_nudge:
        chain.append(b.node("nudge", "nudge", dof="head_yaw", amount=0.2))
    b.chain(*chain, b.output())
    session = EngineSession.create(desk, rate=50, program=b.build())
    try:
        frames = list(session.run_headless(5))
    finally:
        session.engine.close()
    return frames[-1].program[desk.channel_index["head_yaw"]]


def test_the_block_is_in_the_catalog_and_runs_in_a_program(desk, plugin):
    entry = next(e for e in block_catalog() if e["type"] == "nudge")
    assert entry["category"] == "operators" and entry["summary"].startswith("Adds `amount`")
    assert program_output(desk, True) == pytest.approx(program_output(desk, False) + 0.2)


def test_the_command_parses_executes_and_is_in_the_schema(session, plugin):
    assert "wave" in control.command_json_schema()["discriminator"]["mapping"]
    with pytest.raises(control.CommandError) as err:
        control.parse_command({"type": "wave", "energy": 2})
    assert err.value.field == "energy"
    command = control.parse_command({"type": "wave", "energy": 0.8})
    assert control.execute(session, command) == {"arousal": 0.8}
    session.engine.tick()
    assert session.engine.ctx.inputs["arousal"] == 0.8


def test_the_driver_is_on_the_command_line_and_gets_frames(desk, plugin):
    import nutty_gestures.drivers as plugin_drivers

    parser = argparse.ArgumentParser()
    drivers.add_driver_options(parser)
    assert "--tally" in parser.format_help()
    sinks = drivers.build_drivers(desk, parser.parse_args(["--tally", "5", "--sim-servo", "0"]))
    assert [type(s) for s in sinks] == [plugin_drivers.Tally]
    session = EngineSession.create(desk, rate=50)
    session.engine.add_sink(sinks[0])
    list(session.run_headless(50))
    session.engine.close()
    assert len(plugin_drivers.SEEN) == 10  # every 5th of 50 frames


def test_the_importer_is_picked_by_its_suffix(desk, plugin, tmp_path):
    path = tmp_path / "look.tsv"
    path.write_text("time\thead_yaw\n0\t0\n0.5\t0.3\n1\t0\n")
    assert importers.detect_format(path) == "tsv"
    doc, report = importers.import_clip(path, desk)
    assert doc["source"]["format"] == "tsv" and report["format"] == "tsv"
    assert [k["v"] for k in doc["tracks"]["head_yaw"]] == pytest.approx([0.0, 0.3, 0.0])
    assert any(
        "--animation only applies to glTF files" in n
        for n in importers.import_clip(path, desk, animation="x")[1]["notes"]
    )


def test_the_command_is_an_ai_tool_over_http_and_mcp(session, plugin):
    session.engine.start()
    tool = build_tools(session).get("wave_hello")
    assert tool is not None and tool.command == "wave"
    assert tool.parameters["properties"]["energy"]["maximum"] == 1.0
    assert tool.description == "Wave hello, as lively as `energy` says."
    names = [t.name for t in build_tools(session).tools]
    assert names.index("wave_hello") < names.index("stop")  # a plugin's tool goes before stop/cancel/status
    app = create_app(session, frontend_dir=None)
    with TestClient(app) as client:
        answer = client.post("/api/tools/wave_hello", json={"energy": 0.3}).json()
        assert (answer["command"], answer["status"], answer["result"]) == (
            "wave",
            "completed",
            {"arousal": 0.3},
        )

    from backend.mcp_bridge import Remote, create_server

    remote = Remote("http://127.0.0.1:8000")  # served in process: the app itself is the transport
    remote.http = httpx.AsyncClient(transport=httpx.ASGITransport(app=app), base_url=remote.url)
    server, _ = create_server(remote)

    async def main() -> list:
        async with mcp.Client(server, mode="legacy") as client:
            return (await client.list_tools()).tools

    tools = {t.name: t for t in asyncio.run(main())}
    assert tools["wave_hello"].input_schema["properties"]["energy"]["minimum"] == 0.0


def test_without_the_package_its_tool_is_gone(session):
    assert "wave_hello" not in [t.name for t in build_tools(session).tools]


@pytest.mark.parametrize(
    "group, registry",
    [
        ("nutty.blocks", blocks.reload),
        ("nutty.commands", control.REGISTRY.reload),
        ("nutty.drivers", drivers.reload),
        ("nutty.importers", importers.reload),
    ],
)
def test_an_entry_point_that_cannot_load_names_itself(tmp_path, group, registry):
    before = dict(BLOCKS), control.REGISTRY.classes(), dict(drivers.DRIVER_OPTIONS), dict(importers.IMPORTERS)
    entries = {group: {"oops": "nutty_missing_module:Oops"}}
    with installed(tmp_path, "nutty-broken", entries, reload=False), pytest.raises(PluginError) as err:
        registry()
    message = str(err.value)
    assert f"entry point 'oops = nutty_missing_module:Oops' in group '{group}'" in message
    assert "distribution 'nutty-broken 0.1'" in message and "ModuleNotFoundError" in message
    after = dict(BLOCKS), control.REGISTRY.classes(), dict(drivers.DRIVER_OPTIONS), dict(importers.IMPORTERS)
    assert after == before  # the registry kept what it had


@pytest.mark.parametrize(
    "entry, message",
    [
        (
            "wobble = nutty_gestures.blocks:Nudge",
            "declares the name 'nudge'; the entry must be named after it",
        ),
        (
            "math = nutty_gestures.blocks:Math",
            "clashes with entry point 'math = backend.engine.blocks.signals:Math' in group 'nutty.blocks' "
            "of distribution 'nutty",
        ),
        ("nudge = nutty_gestures.blocks:NudgeParams", "is not a Block subclass"),
    ],
)
def test_a_misnamed_clashing_or_wrong_block_names_its_entry(tmp_path, entry, message):
    name, value = (s.strip() for s in entry.split("="))
    files = {**FILES, "nutty_gestures/blocks.py": FILES["nutty_gestures/blocks.py"] + MATH}
    with (
        installed(tmp_path, "nutty-gestures", {"nutty.blocks": {name: value}}, files, reload=False),
        pytest.raises(PluginError, match="distribution 'nutty-gestures 0.1'") as err,
    ):
        blocks.reload()
    assert message in str(err.value)
    assert "math" in BLOCKS and BLOCKS["math"].__module__ == "backend.engine.blocks.signals"


MATH = '''

class Math(Nudge):
    """A second block claiming the bundled type name 'math'."""

    type_name = "math"
'''


def test_bundled_entries_come_first_in_name_order():
    from backend.plugins import entries

    names = [ep.name for ep in entries("nutty.commands")]
    assert names == sorted(names) and names[0] == "cancel"
    assert list(BLOCKS) == sorted(BLOCKS)
    assert np.all([ep.dist.name == "nutty" for ep in entries("nutty.blocks")])

"""The URDF table (backend/engine/urdf_table.py): what the cache gives back is what yourdfpy read, an
edited file is read again, a broken or unwritable cache only costs speed, and with the cache warm a
robot, its chains and the lean `nutty serve` parser load without yourdfpy or the API's routes (the
start-up target of benchmarks/bench_engine.py)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from test_compiled_blocks import ODD_URDF as CHAIN_URDF

from backend.engine import urdf_table as ut
from backend.engine.embodiment import EmbodimentError, load_embodiment
from backend.engine.kinematics import _model_from_table

ROOT = Path(__file__).resolve().parents[1]

# test_compiled_blocks' chain (a prismatic and a mimic joint) with a continuous joint without <limit> and
# a joint velocity of its own: every field's case.
ODD_URDF = (
    CHAIN_URDF.replace(
        'velocity="1" effort="1"/></joint>\n  <joint name="slide"',
        'velocity="1.5" effort="1"/></joint>\n  <joint name="slide"',
    )
    .replace('<link name="tip"/>', '<link name="tip"/><link name="spin"/>')
    .replace(
        "</robot>",
        '  <joint name="wheel" type="continuous"><parent link="base"/><child link="spin"/><axis xyz="0 0 1"/></joint>\n</robot>',
    )
)


@pytest.fixture
def cache(tmp_path, monkeypatch) -> Path:
    folder = tmp_path / "cache"
    monkeypatch.setenv(ut.CACHE_ENV, str(folder))
    ut._table.cache_clear()
    yield folder
    ut._table.cache_clear()


def _fresh(path: Path) -> ut.UrdfTable:
    """The table as read through the cache, with the in-memory copy forgotten."""
    ut._table.cache_clear()
    return ut.urdf_table(path)


@pytest.mark.parametrize("source", ["odd", "nutty_desk"])
def test_the_cached_table_is_what_yourdfpy_read(cache, tmp_path, source):
    if source == "odd":
        path = tmp_path / "odd.urdf"
        path.write_text(ODD_URDF)
    else:
        path = ROOT / "robots" / "nutty_desk" / "robot.urdf"
    read = _fresh(path)  # a miss: read by yourdfpy, then stored
    (stored,) = (cache / "urdf").iterdir()
    assert stored.name.endswith(f"-f{ut.FORMAT}-y{ut._yourdfpy_version()}.json")
    cached = _fresh(path)  # a hit
    assert cached == read
    assert len(read.joints) >= 5 and read.links
    if source == "odd":
        rows = {j.name: j for j in read.joints}
        assert rows["follow"].mimic == ("turn", -0.5, 0.1)
        assert rows["slide"].type == "prismatic" and rows["slide"].upper == 0.3
        assert rows["wheel"].has_limit is False and rows["wheel"].lower is None
        assert rows["turn"].velocity == 1.5
        origin = np.array(rows["turn"].origin).reshape(4, 4)
        assert origin[2, 3] == pytest.approx(0.1) and np.allclose(
            origin[:3, :3] @ origin[:3, :3].T, np.eye(3)
        )


def test_a_robot_and_its_chains_are_the_same_from_the_cache(cache):
    emb = load_embodiment("nutty_desk")  # the table read by yourdfpy
    ut._table.cache_clear()
    again = load_embodiment("nutty_desk")  # from the cache file
    for name in ("min", "max", "vel_limit", "rest"):
        assert np.array_equal(getattr(emb, name), getattr(again, name)), name
    assert emb.joint_names == again.joint_names
    # the chains' model, from yourdfpy's own objects and from the cached table: the same transforms
    import yourdfpy  # lazy: the reference the cache is checked against

    robot = yourdfpy.URDF.load(str(emb.urdf_path), build_scene_graph=False, load_meshes=False).robot
    direct, cached = _model_from_table(ut.table_of_robot(robot)), _model_from_table(_fresh(emb.urdf_path))
    assert direct.root == cached.root and direct.links == cached.links
    for name, joint in direct.joints.items():
        other = cached.joints[name]
        assert np.array_equal(joint.origin, other.origin) and np.array_equal(joint.axis, other.axis), name
        assert (joint.lower, joint.upper, joint.mimic) == (other.lower, other.upper, other.mimic)


def test_an_edited_urdf_is_read_again(cache, tmp_path):
    path = tmp_path / "odd.urdf"
    path.write_text(ODD_URDF)
    assert {j.name: j.upper for j in _fresh(path).joints}["wrist"] == 1.0
    path.write_text(ODD_URDF.replace('lower="-1" upper="1"', 'lower="-1" upper="0.5"'))
    assert {j.name: j.upper for j in _fresh(path).joints}["wrist"] == 0.5
    assert len(list((cache / "urdf").iterdir())) == 2  # one entry per content


def test_a_broken_or_unwritable_cache_only_costs_speed(cache, tmp_path, monkeypatch):
    path = tmp_path / "odd.urdf"
    path.write_text(ODD_URDF)
    good = _fresh(path)
    (stored,) = (cache / "urdf").iterdir()
    stored.write_text(json.dumps({"joints": [{"name": 1}]}))  # not a table: read the URDF again
    assert _fresh(path) == good
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    monkeypatch.setenv(ut.CACHE_ENV, str(blocker))  # the cache folder cannot be made
    assert _fresh(path) == good


def test_a_malformed_urdf_is_refused_with_its_name(cache, tmp_path):
    path = tmp_path / "bad.urdf"
    path.write_text("<robot name='x'><joint name='j' type='revolute'>")
    with pytest.raises(ut.UrdfReadError, match="bad.urdf"):
        _fresh(path)
    with pytest.raises(ut.UrdfReadError, match="missing.urdf"):
        _fresh(tmp_path / "missing.urdf")
    (tmp_path / "robot").mkdir()
    (tmp_path / "robot" / "robot.urdf").write_text(path.read_text())
    with pytest.raises(EmbodimentError, match="cannot read URDF"):
        load_embodiment(tmp_path / "robot" / "robot.urdf")


LEAN_START = """
import sys
from backend.cli import parser_for
parser_for(["serve"]).parse_args(["serve"])
from backend.engine.embodiment import load_embodiment
from backend.session import EngineSession
import json, pathlib
program = pathlib.Path("robots/nutty_desk/programs/interactive.json").read_text()
session = EngineSession.create(load_embodiment("nutty_desk"))
session.load_program(program)
session.engine.run_ticks(3)
print(json.dumps(sorted(m for m in sys.modules if m.split(".")[0] in ("yourdfpy", "trimesh", "fastapi")
                        or m.startswith("backend.commands.") or m.startswith("backend.routes"))))
"""


def test_a_warm_start_needs_neither_yourdfpy_nor_the_api(cache):
    env = {"PATH": "/usr/bin:/bin", ut.CACHE_ENV: str(cache), "PYTHONPATH": str(ROOT)}

    def loaded() -> list[str]:
        out = subprocess.run(
            [sys.executable, "-c", LEAN_START], cwd=ROOT, env=env, capture_output=True, text=True, timeout=120
        )
        assert out.returncode == 0, out.stderr
        return json.loads(out.stdout.strip().splitlines()[-1])

    cold = loaded()
    assert "yourdfpy" in cold  # the first start reads the URDF (and fills the cache)
    warm = loaded()
    # the interactive program's IK and gaze chains came from the cache too
    assert warm == ["backend.commands._common", "backend.commands.serve"], warm

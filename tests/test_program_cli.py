"""The program CLI: `nutty validate`, `nutty new` and `nutty run` with --set and --commands."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from backend.cli import main
from backend.engine.embodiment import load_embodiment

GOLDEN = Path(__file__).parent / "golden"
ROOT = Path(__file__).resolve().parents[1]

TINY_URDF = """<?xml version="1.0"?>
<robot name="tiny">
  <link name="base"/><link name="upper"/><link name="lower"/>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/>
    <axis xyz="0 0 1"/><limit lower="-1.0" upper="1.0" velocity="2.0" effort="1"/></joint>
  <joint name="elbow" type="revolute"><parent link="upper"/><child link="lower"/>
    <axis xyz="0 1 0"/><limit lower="0.2" upper="1.5" velocity="3.0" effort="1"/></joint>
</robot>
"""


def nutty(capsys, *argv: str) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def read_csv(path: Path) -> tuple[list[str], np.ndarray]:
    with path.open() as fh:
        rows = list(csv.reader(fh))
    return rows[0], np.array(rows[1:], dtype=float)


# --- validate -------------------------------------------------------------------------------------


def test_validate_valid_program(capsys):
    code, out, _ = nutty(capsys, "validate", GOLDEN / "valid" / "level2_layers.json", "--robot", "nutty_desk")
    assert code == 0
    assert "valid for robot 'nutty_desk' (APU level 2, 6 nodes, 5 edges)" in out


def test_validate_json_report(capsys):
    code, out, _ = nutty(capsys, "validate", GOLDEN / "valid" / "level3_safe_idle.json", "--json")
    assert code == 0
    report = json.loads(out)
    assert report == {"valid": True, "level": 3, "errors": [], "warnings": []}
    code, out, _ = nutty(
        capsys, "validate", GOLDEN / "invalid" / "unknown_dof.json", "--robot", "nutty_desk", "--json"
    )
    assert code == 1
    report = json.loads(out)
    assert report["valid"] is False and report["level"] == 2
    (err,) = report["errors"]
    assert {k: err[k] for k in ("code", "node", "port")} == {
        "code": "unknown_dof",
        "node": "mixer",
        "port": "layers[1].mask",
    }
    assert "tail" in err["message"] and err["path"] == "nodes[3].params.layers[1].mask[1]"


def test_validate_lists_every_error_for_a_person(capsys, tmp_path):
    doc = json.loads((GOLDEN / "valid" / "level1_chain.json").read_text())
    doc["nodes"][0]["params"]["dofs"] = ["head_yaw", "snout"]
    doc["nodes"][2]["params"]["gain"] = 50
    doc["edges"].append({"from": {"node": "sway", "port": "out"}, "to": {"node": "output", "port": "in"}})
    path = tmp_path / "broken.json"
    path.write_text(json.dumps(doc))
    code, out, _ = nutty(capsys, "validate", path)
    assert code == 1
    lines = out.splitlines()
    assert lines[0] == f"{path}: invalid for robot 'nutty_desk', 3 errors:"
    assert lines[1].startswith("  [unknown_dof] sway.dofs: ") and "snout" in lines[1]
    assert lines[2].startswith("  [invalid_param] scale.gain: ") and "at most 10" in lines[2]
    assert lines[3].startswith("  [multiple_edges] output.in: ")


def test_validate_malformed_json_gives_line_and_column(capsys):
    code, out, _ = nutty(capsys, "validate", GOLDEN / "invalid" / "malformed_json.json")
    assert code == 1
    assert "[malformed_json]" in out and "line 24, column 5" in out


def test_validate_level_limit_and_warnings(capsys, tmp_path):
    code, out, _ = nutty(capsys, "validate", GOLDEN / "valid" / "level3_safe_idle.json", "--max-level", "2")
    assert code == 1 and "[level_too_high] limit: " in out
    doc = json.loads((GOLDEN / "valid" / "level0_rest.json").read_text())
    doc["nodes"].append({"id": "spare", "type": "sine"})
    path = tmp_path / "warn.json"
    path.write_text(json.dumps(doc))
    code, out, _ = nutty(capsys, "validate", path)
    assert code == 0 and "warning [unconnected_node] spare: " in out


def test_validate_cannot_read(capsys, tmp_path):
    code, _, err = nutty(capsys, "validate", tmp_path / "missing.json")
    assert code == 2 and "cannot read program" in err
    code, _, err = nutty(
        capsys, "validate", GOLDEN / "valid" / "level0_rest.json", "--robot", tmp_path / "nobot"
    )
    assert code == 2 and "no robot" in err


def test_validate_as_a_real_command():
    proc = subprocess.run(
        [sys.executable, "-m", "backend.cli", "validate", str(GOLDEN / "invalid" / "cycle.json"), "--json"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 1
    assert [e["code"] for e in json.loads(proc.stdout)["errors"]] == ["cycle"]


# --- new ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("template, level", [("idle", 3), ("blank", 0), ("layers", 3)])
def test_new_writes_a_valid_program(capsys, tmp_path, template, level):
    robot = tmp_path / "tiny.urdf"
    robot.write_text(TINY_URDF)
    for target in ("nutty_desk", robot):
        path = tmp_path / f"{template}_{Path(str(target)).stem}.json"
        code, _, err = nutty(capsys, "new", path, "--robot", target, "--template", template)
        assert code == 0, err
        doc = json.loads(path.read_text())
        assert all({"x", "y"} <= set(n["ui"]) for n in doc["nodes"])
        assert len({(n["ui"]["x"], n["ui"]["y"]) for n in doc["nodes"]}) == len(doc["nodes"])  # no overlaps
        code, out, _ = nutty(capsys, "validate", path, "--robot", target, "--json")
        report = json.loads(out)
        assert code == 0 and report["level"] == level and report["warnings"] == []


def test_new_refuses_to_overwrite(capsys, tmp_path):
    path = tmp_path / "p.json"
    path.write_text("keep me")
    code, _, err = nutty(capsys, "new", path)
    assert code == 2 and "--force" in err and path.read_text() == "keep me"
    code, _, _ = nutty(capsys, "new", path, "--force", "--template", "blank")
    assert code == 0 and json.loads(path.read_text())["nodes"][0]["type"] == "rest_pose"


def test_new_layers_template_switches_its_look_layer(capsys, tmp_path):
    path = tmp_path / "layers.json"
    assert nutty(capsys, "new", path, "--template", "layers")[0] == 0
    commands = tmp_path / "cmd.jsonl"
    commands.write_text('{"t": 1.0, "type": "set_layer", "layer": "look", "active": true, "fade": 0.2}\n')
    out = tmp_path / "out.csv"
    assert (
        nutty(capsys, "run", path, "--seconds", 2, "--rate", 50, "--out", out, "--commands", commands)[0] == 0
    )
    header, data = read_csv(out)
    col = header.index("body_yaw")
    assert abs(data[40, col]) < 0.05 < abs(data[-1, col])


# --- run ------------------------------------------------------------------------------------------


def test_run_writes_exactly_seconds_times_rate_rows(capsys, tmp_path):
    out = tmp_path / "out.csv"
    code, _, err = nutty(
        capsys,
        "run",
        GOLDEN / "valid" / "level3_safe_idle.json",
        "--robot",
        "nutty_desk",
        "--seconds",
        1.5,
        "--rate",
        80,
        "--out",
        out,
    )
    assert code == 0, err
    header, data = read_csv(out)
    assert header == ["t", *load_embodiment("nutty_desk").continuous_names]
    assert data.shape == (120, len(header))
    assert np.allclose(np.diff(data[:, 0]), 1 / 80)
    assert "wrote 120 frames" in err
    # The program's own rate is the default.
    code, _, _ = nutty(
        capsys, "run", GOLDEN / "valid" / "level3_safe_idle.json", "--seconds", 0.5, "--out", out
    )
    assert code == 0 and read_csv(out)[1].shape[0] == 100  # "rate": 200 in the file


def test_run_set_changes_the_output(capsys, tmp_path):
    program = GOLDEN / "valid" / "level1_chain.json"
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    assert nutty(capsys, "run", program, "--seconds", 1, "--out", a)[0] == 0
    assert nutty(capsys, "run", program, "--seconds", 1, "--out", b, "--set", "arousal=2")[0] == 0
    header, da = read_csv(a)
    _, db = read_csv(b)
    col = header.index("head_yaw")
    assert np.ptp(db[:, col]) == pytest.approx(2 * np.ptp(da[:, col]), rel=1e-3)
    code, _, err = nutty(capsys, "run", program, "--seconds", 1, "--out", b, "--set", "arousal=5")
    assert code == 2 and "outside" in err
    code, _, err = nutty(capsys, "run", program, "--seconds", 1, "--out", b, "--set", "calm=1")
    assert code == 2 and "no exposed input 'calm'" in err


def test_run_commands_replays_timed_inputs(capsys, tmp_path):
    program = GOLDEN / "valid" / "level1_chain.json"
    commands = tmp_path / "cmd.jsonl"
    commands.write_text(
        "# arousal drops to zero after half a second\n"
        '{"t": 0.5, "type": "set_input", "name": "arousal", "value": 0.0}\n'
    )
    out = tmp_path / "out.csv"
    code, _, err = nutty(
        capsys, "run", program, "--seconds", 2, "--rate", 100, "--out", out, "--commands", commands
    )
    assert code == 0, err
    header, data = read_csv(out)
    col = header.index("head_yaw")
    assert np.ptp(data[:50, col]) > 0.1
    # Gain 0 around a rest of 0: the program steps to 0 at 0.5 s, and the engine's safety net brings
    # the head there within its limits (brakes, turns back, lands exactly) within a second.
    assert np.all(np.abs(data[50:, col]) <= np.abs(data[50, col]) + 0.02)
    assert np.all(data[150:, col] == 0.0)
    commands.write_text('{"t": 0.5, "type": "set_input", "name": "arousal"}\n')
    code, _, err = nutty(capsys, "run", program, "--seconds", 1, "--out", out, "--commands", commands)
    assert code == 2 and "cmd.jsonl:1" in err


def test_run_invalid_program_prints_every_error(capsys, tmp_path):
    out = tmp_path / "out.csv"
    code, _, err = nutty(
        capsys, "run", GOLDEN / "invalid" / "edge_into_unknown_type.json", "--seconds", 1, "--out", out
    )
    assert code == 1
    assert "[unknown_block_type] breath:" in err


def test_run_unsafe_no_limits_writes_the_programs_own_frames(capsys, tmp_path):
    program = GOLDEN / "valid" / "level1_chain.json"
    commands = tmp_path / "cmd.jsonl"
    commands.write_text('{"t": 0.5, "type": "set_input", "name": "arousal", "value": 0.0}\n')
    safe, raw = tmp_path / "safe.csv", tmp_path / "raw.csv"
    assert (
        nutty(capsys, "run", program, "--seconds", 1, "--rate", 100, "--out", safe, "--commands", commands)[0]
        == 0
    )
    code, _, err = nutty(
        capsys,
        "run",
        program,
        "--seconds",
        1,
        "--rate",
        100,
        "--out",
        raw,
        "--commands",
        commands,
        "--unsafe-no-limits",
    )
    assert code == 0 and "safety net is OFF" in err
    header, s = read_csv(safe)
    _, r = read_csv(raw)
    col = header.index("head_yaw")
    assert np.allclose(r[50:, col], 0.0)  # the program's step, unfiltered
    assert not np.allclose(s[50:60, col], 0.0)  # what the robot is allowed to do

"""Every command-line hint `nutty import` prints parses with the real parser, as written.

The scenarios below trigger each message of backend/importers/ and backend/commands/import_clip.py
that names an option (a swing warning's `--forward` / `--up`, a T-pose's `--skip-frames`, bad data's
`--fill`, a second animation's `--animation`, the limits' `--fit-limits`, ...). In what they print,
each run of options is a hint: `--opt` alone for a flag, `--opt VALUE` or `--opt=VALUE` otherwise, and
options side by side (`--up z --forward=-x`) are parsed together, after `nutty import FILE --out
CLIP`, by backend/cli.py's own parser. Notes ending in "; ignored" echo an option the user gave (which
parsed already) and only have to name a real option. A last test reads the sources: every message
literal naming an option was printed by some scenario, so a new hint cannot go untested.
"""

from __future__ import annotations

import argparse
import ast
import contextlib
import io
import json
import re
import shlex
from pathlib import Path

import numpy as np
import pygltflib
import pytest
from test_import import G, GltfBuilder, build_gltf, qa
from test_import_bvh import JOINTS, NAIVE, motion, write_bvh

from backend.cli import build_parser, main

ROOT = Path(__file__).resolve().parents[1]
SOURCES = [
    *sorted((ROOT / "backend" / "importers").glob("*.py")),
    ROOT / "backend" / "commands" / "import_clip.py",
]
OPTION = re.compile(r"(?<![\w-])(--[a-z][a-z0-9-]*)(?:=('[^']*'|\"[^\"]*\"|[^\s,;)]+))?")
VALUE = re.compile(r"\s('[^']*'|\"[^\"]*\"|[^\s,;:)]+)")


def import_parser() -> argparse.ArgumentParser:
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    return sub.choices["import"]


PARSER = import_parser()
ACTIONS = {opt: a for a in PARSER._actions for opt in a.option_strings}


def hints(text: str) -> list[list[str]]:
    """The hints of a message as argv lists: each run of options (with their values) side by side."""
    runs: list[list[str]] = []
    end = -1
    for line in text.splitlines():
        ignored = line.rstrip().endswith("; ignored")
        for m in OPTION.finditer(line):
            opt = m[1]
            assert opt in ACTIONS, f"'{opt}' is no option of `nutty import`: {line!r}"
            if ignored:
                continue
            if m[2] is not None:
                argv, stop = [f"{opt}={shlex.split(m[2])[0]}"], m.end()
            elif ACTIONS[opt].nargs == 0:
                argv, stop = [opt], m.end()
            else:
                v = VALUE.match(line, m.end())
                assert v is not None, f"'{opt}' takes a value but the hint gives none: {line!r}"
                argv, stop = [opt, shlex.split(v[1])[0]], v.end()
            if runs and line[end : m.start()].strip() == "" and end >= 0:
                runs[-1] += argv
            else:
                runs.append(argv)
            end = stop
        end = -1
    return runs


def parses(argv: list[str]) -> str:
    """'' when `nutty import FILE --out CLIP *argv` parses; else argparse's message."""
    err = io.StringIO()
    try:
        with contextlib.redirect_stderr(err):
            PARSER.parse_args(["anim.glb", "--out", "clip.json", *argv])
    except SystemExit:
        return err.getvalue().strip() or "exit"
    return ""


def nutty(*argv) -> str:
    """What `nutty import ...` prints (stdout and stderr), whatever its exit status."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        main(["import", *[str(a) for a in argv]])
    return out.getvalue() + err.getvalue()


def test_hints_are_found_and_a_bad_one_fails():
    assert hints("... --forward z or --forward=-z turns that axis onto") == [
        ["--forward", "z"],
        ["--forward=-z"],
    ]
    assert hints("with --up z --forward=-x, or") == [["--up", "z", "--forward=-x"]]
    assert hints("--skip-frames 2: dropped; (--fit-limits applies that)") == [
        ["--skip-frames", "2"],
        ["--fit-limits"],
    ]
    assert hints("choose with --animation 1 or --animation 'walk cycle')") == [
        ["--animation", "1"],
        ["--animation", "walk cycle"],
    ]
    assert hints("--up/--forward do not apply to CSV columns; ignored") == []
    assert "expected one argument" in parses(hints("--forward -z turns")[0])  # the old swing hint
    assert "invalid choice" in parses(hints("--fill hold|linear repairs")[0])  # the old bad-data hint


# --------------------------------------------------------------------------------------------------
# The scenarios
# --------------------------------------------------------------------------------------------------


def gltf_animations(path: Path, animations: dict[str, list[tuple[str, str]]], nan_keys: int = 0) -> Path:
    """A glTF file with the named animations, each turning its (node, "yaw" | "tilt") nodes about the
    robot's Z or X axis at 5 keys; the first channel's first `nan_keys` quaternions are NaN."""
    b = GltfBuilder()
    nodes: dict[str, int] = {}
    split: list[tuple[str, int, int]] = []
    for anim, targets in animations.items():
        first = len(b.channels)
        for node, what in targets:
            if node not in nodes:
                nodes[node] = b.node(node)
            q = qa(G([0, 0, 1] if what == "yaw" else [1, 0, 0]), [0.0, 0.1, 0.3, 0.1, 0.0])
            if not b.channels:
                q[1 : 1 + nan_keys] = np.nan
            b.channel(nodes[node], "rotation", [0.0, 0.25, 0.5, 0.75, 1.0], q, "VEC4")
        split.append((anim, first, len(b.channels)))
    b.save(path)
    g = pygltflib.GLTF2().load(str(path))
    channels, samplers = g.animations[0].channels, g.animations[0].samplers
    g.animations = []
    for name, a, z in split:  # each animation its own samplers, renumbered
        g.animations.append(
            pygltflib.Animation(
                name=name,
                samplers=[samplers[c.sampler] for c in channels[a:z]],
                channels=[
                    pygltflib.AnimationChannel(sampler=k, target=c.target)
                    for k, c in enumerate(channels[a:z])
                ],
            )
        )
    g.save_json(str(path))
    return path


def bvh_scenarios(tmp: Path) -> dict[str, str]:
    walk = write_bvh(tmp / "walk.bvh", motion(120))
    naive = tmp / "naive.json"
    naive.write_text(json.dumps(NAIVE))
    yaw_as_pitch = tmp / "yaw_as_pitch.json"
    yaw_as_pitch.write_text(json.dumps({"joints": {"Head": "neck_pitch"}}))
    mot = motion(120)
    mot["Neck"][:, 2] += 20.0
    for j in JOINTS:
        mot[j][0, -3:] = 0.0  # frame 0 is the OFFSET pose: a T-pose
    tpose = write_bvh(tmp / "tpose.bvh", mot)
    mot = motion(120)
    mot["Neck"][5:9, 2] = np.nan
    gap = write_bvh(tmp / "gap.bvh", mot)
    clip = tmp / "c.json"
    return {
        "swing: --forward": nutty(walk, "--map", naive, "--out", clip),
        "swing: --up": nutty(walk, "--map", yaw_as_pitch, "--out", clip),
        "--strict": nutty(walk, "--map", naive, "--out", clip, "--strict"),
        "T-pose": nutty(tpose, "--map", naive, "--forward", "z", "--out", clip),
        "skipped": nutty(tpose, "--map", naive, "--forward", "z", "--out", clip, "--skip-frames", "1"),
        "too many skipped": nutty(walk, "--map", naive, "--out", clip, "--skip-frames", "500"),
        "rest frame": nutty(walk, "--map", naive, "--out", clip, "--rest-frame", "500"),
        "BVH nan": nutty(gap, "--map", naive, "--out", clip),
        "BVH filled": nutty(gap, "--map", naive, "--out", clip, "--fill", "linear"),
        "BVH long gap": nutty(gap, "--map", naive, "--out", clip, "--fill", "hold", "--max-gap", "2"),
        "BVH ignored": nutty(walk, "--map", naive, "--out", clip, "--animation", "1"),
    }


def csv_scenarios(tmp: Path) -> dict[str, str]:
    keys = tmp / "keys.csv"
    keys.write_text("time,head_yaw\n0,0\n0.1,nan\n0.2,1.0\n0.25,-1.0\n")
    smooth = tmp / "smooth.csv"
    smooth.write_text("time,head_yaw\n0,0\n0.3,0.5\n0.6,0\n")
    clip = tmp / "c.json"
    return {
        "CSV nan": nutty(keys, "--out", clip),
        "CSV over the limits": nutty(smooth, "--out", clip, "--interp", "bezier"),
        "CSV fit": nutty(smooth, "--out", clip, "--interp", "bezier", "--fit-limits"),
        "CSV ignored": nutty(keys, "--out", clip, "--fill", "hold", "--forward", "z", "--rest-frame", "1"),
        "CSV no fit": nutty(keys, "--out", clip, "--fill", "hold", "--fit-limits"),
    }


def gltf_scenarios(tmp: Path) -> dict[str, str]:
    anims = {"wave": [("head_yaw", "yaw")], "walk cycle": [("Tail", "yaw")], "the end": [("Tail", "tilt")]}
    three = gltf_animations(tmp / "anims.gltf", anims)
    tail = tmp / "tail.json"
    tail.write_text(json.dumps({"joints": {"Tail": "head_pitch"}}))
    nan = gltf_animations(tmp / "nan.gltf", {"wave": [("head_yaw", "yaw")]}, nan_keys=3)
    clip = tmp / "c.json"
    return {
        "animations": nutty(three, "--out", clip),
        "two animations have it": nutty(three, "--out", clip, "--map", tail),
        "unnamed weights": nutty(build_gltf(tmp / "weights.gltf"), "--out", clip),
        "glTF nan": nutty(nan, "--out", clip),
        "glTF filled": nutty(nan, "--out", clip, "--fill", "hold"),
        "glTF long gap": nutty(nan, "--out", clip, "--fill", "hold", "--max-gap", "2"),
    }


@pytest.fixture(scope="module")
def printed(tmp_path_factory) -> dict[str, str]:
    """Scenario -> what `nutty import` printed."""
    tmp = tmp_path_factory.mktemp("hints")
    return bvh_scenarios(tmp) | csv_scenarios(tmp) | gltf_scenarios(tmp)


def test_every_printed_hint_parses(printed):
    found = {name: hints(text) for name, text in printed.items()}
    assert found["swing: --forward"][-2:] == [["--forward", "z"], ["--forward=-z"]], printed[
        "swing: --forward"
    ]
    assert ["--up", "z", "--forward=-x"] in found["swing: --up"], printed["swing: --up"]
    assert ["--skip-frames", "1"] in found["T-pose"]
    assert ["--fill", "hold"] in found["BVH nan"] and ["--fill", "linear"] in found["BVH nan"]
    assert found["animations"] == [["--animation", "1"], ["--animation", "walk cycle"]], printed["animations"]
    assert found["two animations have it"] == [["--animation", "walk cycle"], ["--animation", "the end"]]
    assert ["--fit-limits"] in found["CSV over the limits"]
    bad = {
        " ".join(argv): (name, why) for name, runs in found.items() for argv in runs if (why := parses(argv))
    }
    assert bad == {}


def message_literals(path: Path) -> list[str]:
    """The constant text of every string in `path` that names an option, except docstrings and argparse's
    own strings (add_argument's names, help, description)."""
    tree = ast.parse(path.read_text())
    skip: set[int] = set()
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if isinstance(body, list) and body and isinstance(body[0], ast.Expr):
            skip.add(id(body[0].value))
        if isinstance(node, ast.Call) and getattr(node.func, "attr", "") in ("add_argument", "add_parser"):
            skip.update(id(n) for arg in [*node.args, *node.keywords] for n in ast.walk(arg))
    out = []
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.JoinedStr):
            skip.update(id(v) for v in node.values)
            parts = [v.value for v in node.values if isinstance(v, ast.Constant) and isinstance(v.value, str)]
        elif isinstance(node, ast.Constant) and isinstance(node.value, str):
            parts = [node.value]
        else:
            continue
        out += [p.strip() for p in parts if OPTION.search(p)]
    return out


NOT_TRIGGERED = {  # message text -> why no scenario prints it
    "(choose one in a --map FILE)": "no robot here has two DoFs whose names differ only in case or separators",
    "--fit-limits: no slow-down fits the limits; not slowed down": "only when no NMF preset could be tried",
}


def test_every_message_naming_an_option_was_printed(printed):
    everything = "\n".join(printed.values())
    literals = {(path.name, text) for path in SOURCES for text in message_literals(path)}
    assert len(literals) > 15
    missing = sorted(
        (name, text) for name, text in literals if text not in everything and text not in NOT_TRIGGERED
    )
    assert missing == []


def test_the_hints_and_commands_in_the_docs_parse():
    """docs/importing.md's command lines and sample output, as printed, parse too."""
    text = (ROOT / "docs" / "importing.md").read_text()
    blocks = [b for lang, b in re.findall(r"```(\w*)\n(.*?)```", text, re.S) if lang not in ("json", "toml")]
    found = [argv for block in blocks for argv in hints(block)]
    assert ["--forward=-z"] in found and ["--fill", "linear"] in found
    assert {" ".join(argv): why for argv in found if (why := parses(argv))} == {}

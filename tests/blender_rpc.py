"""Drive a headless Blender (bpy) process from a test: `Blender().run(code, **args)` runs `code` there
(tests/blender_scripts/rpc_child.py: bpy, the registered add-on, helpers) and returns what it put in
`result`. bpy runs in its own process because it is heavy and keeps global state; one process serves
a whole test module."""

from __future__ import annotations

import json
import os
import queue
import subprocess
import sys
import tempfile
import textwrap
import threading
from pathlib import Path
from typing import Any

CHILD = Path(__file__).resolve().parent / "blender_scripts" / "rpc_child.py"


class BlenderError(RuntimeError):
    """Code run in Blender raised; the message holds its traceback."""


class Blender:
    def __init__(self) -> None:
        self.log = tempfile.TemporaryFile(mode="w+")  # Blender's own output (a file: it never blocks)
        self.proc = subprocess.Popen(
            [sys.executable, str(CHILD)],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=self.log,
            text=True,
            env={**os.environ, "PYTHONUNBUFFERED": "1"},
        )
        self.lines: queue.Queue = queue.Queue()
        threading.Thread(target=self._read, daemon=True).start()
        self.version: str | None = None

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.put(line)
        self.lines.put(None)

    def output(self) -> str:
        self.log.seek(0)
        return self.log.read()[-6000:]

    def _answer(self, timeout: float) -> Any:
        try:
            line = self.lines.get(timeout=timeout)
        except queue.Empty:
            raise BlenderError(f"Blender did not answer within {timeout} s:\n{self.output()}") from None
        if line is None:
            raise BlenderError(f"Blender exited ({self.proc.poll()}):\n{self.output()}")
        reply = json.loads(line)
        if not reply["ok"]:
            raise BlenderError(reply["error"])
        return reply["result"]

    def ready(self, timeout: float = 120.0) -> str:
        """Wait for bpy to start (the child's first line); Blender's version."""
        if self.version is None:
            self.version = self._answer(timeout)["blender"]
        return self.version

    def run(self, code: str, timeout: float = 120.0, **args: Any) -> Any:
        self.ready()
        assert self.proc.stdin is not None
        self.proc.stdin.write(json.dumps({"code": textwrap.dedent(code), "args": args}) + "\n")
        self.proc.stdin.flush()
        return self._answer(timeout)

    def close(self) -> None:
        if self.proc.poll() is None:
            try:
                self.proc.stdin.close()  # type: ignore[union-attr]  # started with stdin=PIPE
                self.proc.wait(15)
            except (OSError, subprocess.TimeoutExpired):
                self.proc.kill()
                self.proc.wait(10)
        self.log.close()


# --- helpers the Blender test modules share ---------------------------------------------------------


def load_rig(blender: Blender, url: str) -> dict[str, Any]:
    """A fresh scene with the robot loaded from `url`; the rig's name, bones and joint map."""
    return blender.run(
        """
        reset_scene()
        bpy.context.scene.nutty.server_url = args["url"]
        bpy.ops.nutty.load_robot()
        rig = bpy.context.view_layer.objects.active
        plan = nutty_blender.rig.plan_of(rig)
        result = {"name": rig.name, "joint_bones": plan.joint_bones, "dof_bones": plan.dof_bones,
                  "bones": [b.name for b in rig.data.bones], "meshes": sorted(c.name for c in rig.children)}
    """,
        url=url,
    )


def joint_map(robot: dict[str, Any], rig: dict[str, Any]) -> dict[str, Any]:
    """joint -> its bone, its parent joint's bone and its axis: what `joint_angles` reads in Blender."""
    frames = robot["joint_frames"]
    return {
        j: {
            "bone": b,
            "axis": frames[j]["axis"],
            "parent": rig["joint_bones"][frames[j]["parent_joint"]] if frames[j]["parent_joint"] else None,
        }
        for j, b in rig["joint_bones"].items()
    }

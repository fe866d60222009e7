"""The bundled robot's hardware file for servers that run its servos on the in-process emulators
(`--hardware-emulator`) during the test suite.

The emulators are Python threads of the server, which a CI machine running other tests beside it can
hold off longer than real servos ever take to answer; the bundled 100 ms `no_answer_ms` would then turn
that stall into servo faults. This copy allows 1 s: the tests that use it are about the healthy path,
and tests/test_hardware_driver.py checks the fault path at tight thresholds.
"""

from __future__ import annotations

from pathlib import Path

import yaml

BUNDLED = Path(__file__).resolve().parents[1] / "robots" / "nutty_desk" / "hardware.yaml"
NO_ANSWER_MS = 1000


def emulated_hardware_file(folder: Path) -> Path:
    data = yaml.safe_load(BUNDLED.read_text())
    data["no_answer_ms"] = NO_ANSWER_MS
    path = folder / "hardware.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path

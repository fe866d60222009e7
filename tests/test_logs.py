"""Logging for the long-running commands (backend/logs.py): levels, text and JSON lines, the options
on `nutty serve`, `nutty bridge` and `nutty mcp`, and the throttle for faults that recur every tick."""

from __future__ import annotations

import io
import json
import logging
import subprocess
import sys

import pytest

from backend import logs
from backend.cli import build_parser


@pytest.fixture()
def restore_logging():
    """Put the root logger and the library loggers back as they were (configure_logging changes them)."""
    names = ("", *logs.UVICORN_LOGGERS, *logs.CHATTY_LOGGERS)
    levels = {n: logging.getLogger(n).level for n in names}
    handlers = list(logging.getLogger().handlers)
    settings = logs._settings
    yield
    root = logging.getLogger()
    for h in [h for h in root.handlers if h not in handlers]:
        root.removeHandler(h)
    for n, level in levels.items():
        logging.getLogger(n).setLevel(level)
    logging.captureWarnings(False)
    logs._settings = settings


def test_configure_logging_sets_the_levels(restore_logging):
    out = io.StringIO()
    logs.configure_logging("warning", stream=out)
    assert logging.getLogger().level == logging.WARNING
    assert all(logging.getLogger(n).level == logging.WARNING for n in logs.UVICORN_LOGGERS)
    logging.getLogger("backend.test").info("not shown")
    logging.getLogger("backend.test").warning("shown")
    assert "not shown" not in out.getvalue() and "WARNING backend.test: shown" in out.getvalue()

    logs.configure_logging("debug", stream=out)
    assert logging.getLogger().level == logging.DEBUG
    assert logging.getLogger("uvicorn.error").level == logging.DEBUG
    assert logging.getLogger("httpx").level == logging.DEBUG  # per-request lines at debug only
    ours = [h for h in logging.getLogger().handlers if isinstance(h, logs._NuttyHandler)]
    assert len(ours) == 1  # a second call replaces the first handler

    logs.configure_logging("info", stream=out)
    assert logging.getLogger().level == logging.INFO
    assert logging.getLogger("uvicorn.error").level == logging.INFO
    assert logging.getLogger("httpx").level == logging.WARNING
    assert logging.getLogger("uvicorn.access").level == logging.WARNING
    assert logs.settings() == ("info", False)


def test_json_lines_parse_with_their_fields(restore_logging):
    out = io.StringIO()
    logs.configure_logging("info", json_lines=True, stream=out)
    log = logging.getLogger("backend.test")
    log.info("hello %s", "robot")
    try:
        raise ValueError("broken block")
    except ValueError:
        log.exception("a block failed")
    lines = out.getvalue().splitlines()
    assert len(lines) == 2
    first, second = (json.loads(line) for line in lines)
    assert set(first) == {"time", "level", "logger", "message"}
    assert (
        first["level"] == "INFO" and first["logger"] == "backend.test" and first["message"] == "hello robot"
    )
    assert first["time"].endswith("+00:00") and "T" in first["time"]
    assert second["level"] == "ERROR" and second["message"] == "a block failed"
    assert "Traceback" in second["exc_info"] and "ValueError: broken block" in second["exc_info"]


def test_direct_lines_match_the_configured_form(restore_logging):
    logs.configure_logging("info", json_lines=True, stream=io.StringIO())
    doc = json.loads(logs.direct_line("backend.shutdown", logging.WARNING, "SIGINT again: hurrying"))
    assert doc["level"] == "WARNING" and doc["logger"] == "backend.shutdown"
    assert doc["message"] == "SIGINT again: hurrying"
    logs.configure_logging("info", stream=io.StringIO())
    text = logs.direct_line("backend.shutdown", logging.WARNING, "two\nlines").decode()
    assert text.endswith(" WARNING backend.shutdown: two lines\n") and text.count("\n") == 1


def test_bad_levels_are_refused():
    with pytest.raises(ValueError, match="log level"):
        logs.configure_logging("verbose")


@pytest.mark.parametrize("command", ["serve", "bridge", "mcp"])
def test_the_long_running_commands_take_the_options(command, capsys):
    parser = build_parser()
    with pytest.raises(SystemExit):
        parser.parse_args([command, "--help"])
    text = capsys.readouterr().out
    assert "--log-level {debug,info,warning,error}" in text and "--log-json" in text
    required = {"bridge": ["--zenoh", "--robot-id", "r1", "--driver", "osc", "--robot", "nutty_desk"]}
    args = parser.parse_args([command, *required.get(command, []), "--log-level", "DEBUG", "--log-json"])
    assert args.log_level == "debug" and args.log_json is True
    defaults = parser.parse_args([command, *required.get(command, [])])
    assert defaults.log_level == "info" and defaults.log_json is False


def test_help_shows_the_options_from_the_command_line():
    for command in ("serve", "bridge", "mcp"):
        out = subprocess.run(
            [sys.executable, "-m", "backend.cli", command, "--help"],
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert out.returncode == 0, out.stderr
        assert "--log-level" in out.stdout and "--log-json" in out.stdout, out.stdout


def test_configure_from_args_leaves_other_commands_alone(restore_logging):
    args = build_parser().parse_args(["validate", "program.json"])
    assert logs.configure_from_args(args) is False


def test_the_throttle_logs_a_kind_at_most_every_period():
    now = [0.0]
    throttle = logs.Throttle(every=10.0, clock=lambda: now[0])
    assert throttle.due("ValueError") == 0
    assert throttle.due("ValueError") is None  # the same kind again at once: held back
    assert throttle.due("KeyError") == 0  # another kind: at once
    now[0] = 5.0
    assert throttle.due("ValueError") is None
    now[0] = 10.5
    assert throttle.due("ValueError") == 2  # due again, saying how many were held back


def test_a_faulty_block_is_logged_once_per_period_and_still_evented(desk, caplog, monkeypatch):
    from backend.engine import runtime
    from backend.graph.builder import ProgramBuilder
    from backend.session import EngineSession

    monkeypatch.setattr(runtime, "_faults", logs.Throttle(every=3600.0))
    b = ProgramBuilder("faulty")
    b.chain(b.node("sine", "wave", dofs=["head_yaw"], amplitude=0.3, frequency=1.0), b.output())
    session = EngineSession.create(desk, rate=100, program=b.build())
    notes = []
    session.on_note(notes.append)
    try:
        list(session.run_headless(3))
        # a bug in a block: its state is lost (its own tick and the compiled core's op both read it)
        session.engine.apu.block("wave").state = None
        with caplog.at_level(logging.ERROR, logger="backend.engine.runtime"):
            frames = list(session.run_headless(5))
        assert len(frames) == 5  # the clock goes on (holding the last pose: tests/test_runtime.py)
        assert len([n for n in notes if n["event"] == "error"]) == 5  # every tick's fault is evented
        faults = [r for r in caplog.records if "a block failed" in r.getMessage()]
        assert len(faults) == 1 and "AttributeError" in faults[0].getMessage()  # logged once
        assert faults[0].exc_info is not None
    finally:
        session.engine.close()


@pytest.mark.slow
def test_a_served_robot_logs_json_lines_to_stderr_only(tmp_path):
    """`nutty serve --log-json`: every stderr line is one JSON object (uvicorn's lines and the
    shutdown's, the signal handler's included), and stdout keeps the banner."""
    import os
    import signal
    import time

    from tests.server_process import free_port, stop_process

    port = free_port()
    out, err = (tmp_path / "stdout.txt").open("w+"), (tmp_path / "stderr.txt").open("w+")
    proc = subprocess.Popen(
        [sys.executable, "-m", "backend.cli", "serve", "--no-previz", "--port", str(port), "--log-json"],
        stdout=out,
        stderr=err,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    try:
        deadline = time.time() + 120
        while "Uvicorn running" not in (tmp_path / "stderr.txt").read_text():
            assert proc.poll() is None and time.time() < deadline, (tmp_path / "stderr.txt").read_text()
            time.sleep(0.2)
        proc.send_signal(signal.SIGTERM)
        time.sleep(0.2)
        proc.send_signal(signal.SIGTERM)  # the second is reported from the signal handler itself
        assert proc.wait(30) == 0
    finally:
        stop_process(proc)
        out.close()
        err.close()
    lines = (tmp_path / "stderr.txt").read_text().splitlines()
    docs = [json.loads(line) for line in lines]  # every line parses
    assert all({"time", "level", "logger", "message"} <= set(d) for d in docs)
    said = [d["message"] for d in docs if d["logger"] == "backend.shutdown"]
    assert any("taking the robot to rest" in m for m in said), said
    assert any("hurrying" in m for m in said) and any("drivers closed" in m for m in said), said
    assert any(d["logger"].startswith("uvicorn") for d in docs)
    assert "editor   http://localhost" in (tmp_path / "stdout.txt").read_text()

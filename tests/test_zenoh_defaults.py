"""Zenoh secure by default: loopback and no multicast scouting unless asked, a warning when listening
beyond loopback without access control, `--token --zenoh` refused without access control, and the
router honouring its config's listen endpoints. Everything here stays on loopback."""

from __future__ import annotations

import json
import subprocess
import sys
import time

import pytest
from test_authority import _listening

from backend.cli import main
from backend.zenoh_link.session import ZenohOptions, is_loopback_endpoint
from tests.server_process import free_port, stop_process


def setting(options: ZenohOptions, key: str):
    return json.loads(options.config().get_json(key))


def test_by_default_a_session_listens_on_loopback_and_does_not_scout():
    opts = ZenohOptions()
    assert (
        opts.listen_endpoints() == ["tcp/127.0.0.1:0"]
        and setting(opts, "scouting/multicast/enabled") is False
    )
    assert opts.exposure_warning() is None
    assert setting(ZenohOptions(scout=True), "scouting/multicast/enabled") is True
    wide = ZenohOptions(listen=["tcp/0.0.0.0:7447"])
    assert wide.listen_endpoints() == ["tcp/0.0.0.0:7447"]
    assert "tcp/0.0.0.0:7447" in wide.exposure_warning() and "access control" in wide.exposure_warning()


def test_a_config_file_decides_what_it_sets(tmp_path):
    f = tmp_path / "z.json5"
    f.write_text(
        '{ listen: { endpoints: ["tcp/0.0.0.0:7000"] }, scouting: { multicast: { enabled: true } } }'
    )
    opts = ZenohOptions(config_file=str(f))
    assert (
        opts.listen_endpoints() == ["tcp/0.0.0.0:7000"]
        and setting(opts, "scouting/multicast/enabled") is True
    )
    acl = tmp_path / "acl.json5"
    acl.write_text(
        '{ listen: { endpoints: ["tcp/0.0.0.0:7000"] }, access_control: { enabled: true, '
        'default_permission: "deny" } }'
    )
    assert ZenohOptions(config_file=str(acl)).exposure_warning() is None  # access control: no warning
    quiet = tmp_path / "q.json5"
    quiet.write_text("{ mode: 'peer' }  // says nothing of listening or scouting")
    opts = ZenohOptions(config_file=str(quiet))
    assert (
        opts.listen_endpoints() == ["tcp/127.0.0.1:0"]
        and setting(opts, "scouting/multicast/enabled") is False
    )


@pytest.mark.parametrize(
    "endpoint, local",
    [
        ("tcp/127.0.0.1:7447", True),
        ("tcp/[::1]:7447", True),
        ("tcp/localhost:1", True),
        ("tcp/0.0.0.0:7447", False),
        ("tls/192.168.1.2:7447", False),
        ("tcp/[::]:0", False),
    ],
)
def test_loopback_endpoints(endpoint, local):
    assert is_loopback_endpoint(endpoint) is local


def test_a_real_session_opened_by_default_listens_on_loopback_only():
    import os

    before = set(_listening(os.getpid()))  # (other tests' servers in this process, if any)
    session = ZenohOptions().open()
    try:
        opened = set(_listening(os.getpid())) - before
        assert opened and all(a in ("127.0.0.1", "::1") for a, _ in opened), opened
    finally:
        session.close()


def test_serve_refuses_a_token_with_zenoh_without_access_control(capsys):
    try:
        code = main(["serve", "--no-previz", "--zenoh", "--token", "s3cret", "--port", str(free_port())])
    except SystemExit as exc:
        code = exc.code
    err = capsys.readouterr().err
    assert code == 2 and "--token guards HTTP only" in err and "docs/fleet.md#security" in err


def test_the_router_listens_where_its_config_says(tmp_path):
    port = free_port()
    f = tmp_path / "router.json5"
    f.write_text('{ listen: { endpoints: ["tcp/127.0.0.1:' + str(port) + '"] } }')
    proc = subprocess.Popen(
        [sys.executable, "-m", "backend.cli", "fleet", "router", "--zenoh-config", str(f)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        deadline = time.monotonic() + 60
        while ("127.0.0.1", port) not in _listening(proc.pid):
            assert proc.poll() is None and time.monotonic() < deadline, (
                proc.stderr.read() if proc.poll() else ""
            )
            time.sleep(0.1)
        assert [(a, p) for a, p in _listening(proc.pid)] == [("127.0.0.1", port)]  # not 0.0.0.0:7447
    finally:
        stop_process(proc)
    _out, err = proc.communicate()
    assert "warning" not in err  # loopback only: nothing to warn about

"""backend.security in isolation: the one JSON-safety validator every entry point shares, safe
serialisation, and the Origin/Host/token policy."""

from __future__ import annotations

import json

import numpy as np
import pytest

from backend import control
from backend.security import AccessPolicy, JsonSafetyError, check_json, default_origins, dumps, loads


@pytest.mark.parametrize(
    "raw, code, field",
    [
        (b"NaN", "non_finite", None),
        (b'{"a": [1, Infinity]}', "non_finite", None),
        (b'{"a": [1, 1e999]}', "non_finite", "a[1]"),
        (b'{"a": {"b": -1e400}}', "non_finite", "a.b"),
        (b'{"t": "\\ud800"}', "invalid_unicode", "t"),
        (b'{"\\udfff": 1}', "invalid_unicode", None),
        (b"\xff\xfe{}", "invalid_unicode", None),
        (b'{"n": 99999999999999999999999}', "number_too_large", "n"),
        (b"[" * 65 + b"]" * 65, "too_deep", None),
        (b"[" * 100_000 + b"]" * 100_000, "too_deep", None),
        (b"{", "malformed_json", None),
        (b"1" * 5000, "malformed_json", None),
    ],
)
def test_loads_refuses_with_a_code_and_the_field(raw, code, field):
    with pytest.raises(JsonSafetyError) as err:
        loads(raw)
    assert err.value.code == code and 400 <= err.value.status < 500
    if field is not None:
        assert err.value.field == field
    json.dumps({"message": str(err.value)}).encode("utf-8")  # the error itself always serialises


def test_loads_accepts_the_limits():
    assert loads(b"[" * 64 + b"]" * 64) is not None
    assert loads(b'{"n": 9223372036854775808, "x": -0.0, "s": "\\u00e9\\ud83d\\ude00"}')["s"] == "é😀"
    with pytest.raises(JsonSafetyError) as err:
        loads(b"x" * 11, max_bytes=10)
    assert err.value.status == 413


def test_commands_share_the_validator_for_in_process_callers():
    for bad, field in [
        ({"type": "set_input", "name": "a", "value": float("nan")}, "value"),
        ({"type": "set_gaze", "target": [np.float64("inf"), 0, 0]}, "target[0]"),
        ({"type": "say", "text": "\udc00"}, "text"),
    ]:
        with pytest.raises(control.CommandError) as err:
            control.parse_command(bad)
        assert err.value.field == field


def test_dumps_never_fails():
    text = dumps({"message": "bad \ud800 name", "x": float("nan"), "y": [np.float32(1.5)], "z": object()})
    doc = json.loads(text)
    assert doc["x"] is None and doc["y"] == [1.5] and "\\ud800" in doc["message"]
    text.encode("utf-8")
    assert dumps({"ok": [1, "é"]}) == '{"ok":[1,"é"]}'


def test_dumps_writes_the_values_the_standard_library_would():
    """orjson writes what json.dumps (and the sanitiser after it) would: keys of any JSON type as
    strings, numpy numbers as floats, non-finite numbers as null; what orjson refuses (an integer past
    64 bits, a lone surrogate) goes the standard library's way."""
    value = {
        "a": [1, 2.5, -0.0, 1e-05, 1e16, True, None, "é"],
        1: "one",
        2.5: "x",
        None: "n",
        "np": [np.float64(0.1), np.int64(3), np.float32(np.inf)],
        "t": (1, 2),
        "nested": {"deep": [{"x": float("-inf")}]},
    }
    same = {
        "a": [1, 2.5, -0.0, 1e-05, 1e16, True, None, "é"],
        1: "one",
        2.5: "x",
        None: "n",
        "np": [0.1, 3.0, None],
        "t": [1, 2],
        "nested": {"deep": [{"x": None}]},
    }
    assert json.loads(dumps(value)) == json.loads(json.dumps(same))
    assert json.loads(dumps({"big": 2**70, "x": np.float64(1.5)})) == {"big": 2**70, "x": 1.5}
    assert dumps({"s": "lone \udc80"}) == json.dumps({"s": "lone \\udc80"}, separators=(",", ":"))


def test_origin_and_host_policy():
    p = AccessPolicy(port=8000, bind_host="127.0.0.1", allowed_origins=["https://app.example"])
    assert set(default_origins("127.0.0.1", 8000)) == {
        "http://localhost:8000",
        "http://127.0.0.1:8000",
        "http://[::1]:8000",
    }
    for origin in (
        "http://localhost:8000",
        "http://127.0.0.1:8000",
        "http://[::1]:8000",
        "https://app.example",
        None,
    ):
        assert p.origin_problem(origin, "127.0.0.1:8000") is None, origin
    for origin in (
        "http://evil.example",
        "null",
        "http://localhost:8001",
        "file://",
        "http://localhost:8000/x",
        "http://localhost:8000, http://evil.example",
    ):
        assert p.origin_problem(origin, "127.0.0.1:8000") is not None, origin
    for host in ("127.0.0.1:8000", "localhost:8000", "[::1]:8000", "app.example:443", "app.example:8000"):
        assert p.host_problem(host) is None, host
    for host in (
        "evil.example:8000",
        "127.0.0.1:8001",
        "localhost",
        "10.0.0.2:8000",
        "",
        None,
        "a:b:c",
        "127.0.0.1:8000, evil.example",
    ):
        assert p.host_problem(host) is not None, host
    wide = AccessPolicy(port=8000, bind_host="0.0.0.0")
    assert wide.host_problem("192.168.1.20:8000") is None and wide.host_problem("[fe80::1]:8000") is None
    assert wide.host_problem("robot.local:8000") is not None  # names must be allowed explicitly
    assert wide.origin_problem("http://192.168.1.20:8000", "192.168.1.20:8000") is None  # same origin
    assert wide.origin_problem("http://192.168.1.20:8000", "evil.example:8000") is not None
    with pytest.raises(ValueError):
        AccessPolicy(port=1, allowed_origins=["not an origin"])


def test_token_forms():
    p = AccessPolicy(token="T0k")
    assert p.token_ok({"authorization": "Bearer T0k"}, "")
    assert p.token_ok({}, "token=T0k")
    assert not p.token_ok({"authorization": "Bearer x"}, "token=x")
    assert not p.token_ok({}, "")
    assert AccessPolicy().token_ok({}, "")


def test_check_json_walks_any_depth_without_recursion():
    deep: list = []
    cur = deep
    for _ in range(10_000):
        cur.append([])
        cur = cur[0]
    with pytest.raises(JsonSafetyError) as err:
        check_json(deep)
    assert err.value.code == "too_deep"


def test_an_allowed_origin_behind_a_reverse_proxy():
    p = AccessPolicy(port=8000, allowed_origins=["https://robot.example"])
    for host in ("robot.example", "robot.example:443", "robot.example:8000"):
        assert p.host_problem(host, "http") is None, host
    assert p.host_problem("robot.example:9999") is not None
    assert p.origin_problem("https://robot.example", "robot.example") is None

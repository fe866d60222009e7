"""Hostile input against a real `nutty serve`: no request gets a 5xx, no recoverable error drops a
WebSocket, and a rejected request changes nothing (the running program and the exposed inputs are
read back after every rejection).

Property-based (hypothesis, derandomised, bounded example counts): random JSON values, command-shaped
objects with wrong types, deep nesting, huge strings, NaN/inf, lone surrogates, invalid UTF-8 and
binary frames, sent to every JSON body route and to /ws/control. Each case the issue reported is
also its own test below. The server runs on a copy of the bundled robot, so nothing is written into
the repository.
"""

from __future__ import annotations

import json
import shutil
import socket
from pathlib import Path

import httpx
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from server_process import running_server_proc
from websockets.sync.client import connect as ws_connect

ROBOT = Path(__file__).resolve().parents[1] / "robots" / "nutty_desk"
REST_EXAMPLES = 200
WS_EXAMPLES = 200
SENT = {"rest": 0, "ws": 0}  # hostile requests/messages sent, reported at the end of the module
STATUSES: dict[int | str, int] = {}  # status codes / WebSocket reply codes seen

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    robot = tmp_path_factory.mktemp("robot") / "nutty_desk"
    shutil.copytree(ROBOT, robot)
    with running_server_proc("--robot", str(robot), "--no-previz", "--sim-servo", "0") as srv:
        http = httpx.Client(base_url=srv.url, timeout=30.0)
        program = http.get("/api/program").json()["program"]
        srv.http = http
        srv.robot = robot
        srv.program = program
        srv.node = "breathe"
        srv.params = next(n for n in program["nodes"] if n["id"] == "breathe")["params"]
        srv.clip = json.loads((ROBOT / "clips" / "nod.json").read_text())
        srv.state = _state(http)
        yield srv
        http.close()
    print(
        f"\nhostile suite: {SENT['rest']} REST requests, {SENT['ws']} WebSocket messages; "
        f"answers: {dict(sorted(STATUSES.items(), key=lambda kv: -kv[1]))}"
    )


def _state(http: httpx.Client) -> tuple[str, str]:
    """What a rejected request must leave alone: the running program and the exposed inputs."""
    return http.get("/api/program").text, json.dumps(http.get("/api/inputs").json()["values"], sort_keys=True)


def _routes(node: str) -> list[tuple[str, str]]:
    return [
        ("POST", "/api/commands"),
        ("PUT", "/api/program"),
        ("POST", "/api/program/validate"),
        ("PATCH", f"/api/program/nodes/{node}/params"),
        ("PUT", "/api/inputs/arousal"),
        ("PUT", "/api/inputs/gaze_target"),
        ("PUT", "/api/postures/hostile"),
        ("PUT", "/api/clips/hostile"),
        ("PUT", "/api/programs/hostile"),
        ("POST", "/api/blocks/layer_mixer/ports"),
        ("PUT", "/api/previz/ghost"),
    ]


def _check_response(srv, r: httpx.Response) -> None:
    STATUSES[r.status_code] = STATUSES.get(r.status_code, 0) + 1
    assert r.status_code < 500, (r.status_code, r.text[:500])
    body = r.json()  # always JSON, never a traceback
    if r.status_code >= 400:
        assert isinstance(body["detail"]["code"], str) and isinstance(body["detail"]["message"], str)
        assert "Traceback" not in r.text
        assert _state(srv.http) == srv.state, "a rejected request changed the program or the inputs"
    else:
        srv.state = _state(srv.http)  # an accepted one may change them


# --- strategies ------------------------------------------------------------------------------------------------

surrogates = st.integers(0xD800, 0xDFFF).map(chr)
huge = st.integers(1_000, 300_000).map(lambda n: "x" * n)
small_strings = st.one_of(
    st.text(max_size=30),
    st.lists(st.one_of(surrogates, st.characters()), max_size=8).map("".join),
    st.sampled_from(["wave", "gesture", "happy", "arousal", "breathe", "smile", "chirp", ""]),
)
strings = st.one_of(small_strings, small_strings, small_strings, small_strings, huge)  # huge ones 1 in 5
numbers = st.one_of(
    st.integers(-(2**70), 2**70),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([float("nan"), float("inf"), -float("inf"), 1e308, 2**64, -0.0, 0.5]),
)
scalars = st.one_of(st.none(), st.booleans(), numbers, strings)
values = st.recursive(
    scalars,
    lambda kids: st.one_of(st.lists(kids, max_size=5), st.dictionaries(strings, kids, max_size=5)),
    max_leaves=20,
)
FIELDS = [
    "id",
    "clip",
    "speed",
    "mode",
    "anchors",
    "node",
    "layer",
    "t",
    "posture",
    "duration",
    "easing",
    "target",
    "name",
    "value",
    "values",
    "active",
    "fade",
    "mixer",
    "text",
    "sound",
    "dof",
    "colour",
    "expression",
    "valence",
    "arousal",
    "visible",
    "params",
    "nodes",
    "edges",
    "format",
    "tracks",
]
TEMPLATES = [  # valid commands for the bundled interactive program; one field at a time goes wrong
    {"type": "play_clip", "clip": "wave", "layer": "gesture", "speed": 1.5},
    {"type": "stop_clip", "fade": 0.2},
    {"type": "seek_clip", "t": 0.1},
    {"type": "go_posture", "posture": "happy", "duration": 0.2, "easing": "sine"},
    {"type": "set_gaze", "target": [0.6, 0.1, 0.3]},
    {"type": "set_input", "name": "arousal", "value": 0.2},
    {"type": "set_inputs", "values": {"valence": 0.1, "arousal": -0.1}},
    {"type": "set_layer", "layer": "idle", "active": True, "fade": 0.2},
    {"type": "say", "text": "hi"},
    {"type": "play_sound", "sound": "chirp"},
    {"type": "set_led", "colour": [1, 0, 0]},
    {"type": "set_face", "expression": "smile"},
    {"type": "set_emotion", "valence": 0.1, "arousal": 0.1},
    {"type": "cancel", "target": "nothing"},
    {"type": "reset", "fade": 0.1},
]


def _mutate(draw, doc):
    """`doc` with one field (at any depth) replaced by, or one key added with, a hostile value."""
    doc = json.loads(json.dumps(doc))
    holders = []

    def walk(v):
        if isinstance(v, dict):
            holders.append(v)
            for x in v.values():
                walk(x)
        elif isinstance(v, list):
            holders.append(v)
            for x in v:
                walk(x)

    walk(doc)
    holder = draw(st.sampled_from(holders))
    if isinstance(holder, dict):
        key = draw(st.one_of(st.sampled_from(sorted(holder) or ["x"]), st.sampled_from(FIELDS)))
        holder[key] = draw(values)
    elif holder:
        holder[draw(st.integers(0, len(holder) - 1))] = draw(values)
    else:
        holder.append(draw(values))
    return doc


shaped = st.builds(
    lambda t, extra: {"type": t, **extra},
    st.sampled_from([c["type"] for c in TEMPLATES] + ["dance"]),
    st.dictionaries(st.sampled_from(FIELDS), values, max_size=4),
)
documents = st.one_of(values, shaped, st.dictionaries(st.sampled_from(FIELDS), values, max_size=5))


def _encode(v) -> bytes:
    # allow_nan: NaN/Infinity literals on the wire; ensure_ascii: lone surrogates as \udXXX escapes
    return json.dumps(v, allow_nan=True).encode()


nested = st.integers(60, 5_000).map(lambda d: ("[" * d + "]" * d).encode())
nested_objects = st.integers(60, 3_000).map(lambda d: ('{"a":' * d + "1" + "}" * d).encode())
raw_bodies = st.one_of(
    documents.map(_encode),
    nested,
    nested_objects,
    st.binary(max_size=64),
    st.text(max_size=64).map(lambda s: s.encode("utf-8", "surrogatepass")),
    st.integers(900_000, 1_200_000).map(lambda n: b'"' + b"y" * n + b'"'),
)
HOSTILE = settings(
    max_examples=REST_EXAMPLES,
    derandomize=True,
    deadline=None,
    database=None,
    suppress_health_check=list(HealthCheck),
)


def _plausible(draw, srv, path: str):
    """A body that is right but for one field: the running program, a node's params, a command."""
    if path in ("/api/program", "/api/program/validate", "/api/programs/hostile"):
        return _mutate(draw, srv.program)
    if "/params" in path:
        return _mutate(draw, srv.params)
    if path == "/api/commands":
        return _mutate(draw, draw(st.sampled_from(TEMPLATES)))
    if path.startswith("/api/inputs/"):
        return _mutate(draw, {"value": [0.5, 0.0, 0.3] if path.endswith("gaze_target") else 0.2})
    if path.startswith("/api/postures/"):
        return _mutate(
            draw, {"name": "p", "values": {"head_yaw": 0.2, "mouth": "smile", "eye_leds": [1, 0, 0]}}
        )
    if path.startswith("/api/clips/"):
        return _mutate(draw, srv.clip)
    if path.startswith("/api/blocks/"):
        return _mutate(draw, {"params": {"layers": [{"name": "a"}, {"name": "b", "mode": "additive"}]}})
    return _mutate(draw, {"visible": True})


# --- properties ------------------------------------------------------------------------------------------------


@HOSTILE
@given(data=st.data())
def test_rest_body_routes_never_5xx_and_rejections_change_nothing(server, data):
    method, path = data.draw(st.sampled_from(_routes(server.node)))
    if data.draw(st.booleans()):
        body = _encode(_plausible(data.draw, server, path))
    else:
        body = data.draw(raw_bodies)
    r = server.http.request(method, path, content=body, headers={"content-type": "application/json"})
    SENT["rest"] += 1
    _check_response(server, r)


ws_messages = st.one_of(
    documents.map(lambda v: json.dumps(v, allow_nan=True)),
    st.sampled_from(TEMPLATES),
    st.binary(max_size=256),
    st.text(max_size=40),
    nested.map(bytes.decode),
    st.integers(60_000, 200_000).map(lambda n: json.dumps({"type": "say", "text": "z" * n})),
)


@settings(HOSTILE, max_examples=WS_EXAMPLES)
@given(data=st.data())
def test_ws_control_answers_everything_and_stays_open(server, control_socket, data):
    message = data.draw(ws_messages)
    if isinstance(message, dict):
        message = json.dumps(_mutate(data.draw, message), allow_nan=True)
    control_socket.send(message)
    SENT["ws"] += 1
    reply = _reply(control_socket)
    assert reply["type"] in ("ack", "error"), reply
    key = f"ws:{reply.get('code', reply['type'])}"
    STATUSES[key] = STATUSES.get(key, 0) + 1
    if reply["type"] == "error":
        assert isinstance(reply["code"], str) and isinstance(reply["message"], str)
        assert _state(server.http) == server.state, "a rejected command changed the program or the inputs"
    else:
        server.state = _state(server.http)


@pytest.fixture(scope="module")
def control_socket(server):
    # no keepalive pings: their payloads come from `random`, which hypothesis flags mid-example
    with ws_connect(f"ws://127.0.0.1:{server.port}/ws/control", max_size=None, ping_interval=None) as ws:
        yield ws


def _reply(ws, timeout: float = 30.0) -> dict:
    """The next ack or error on /ws/control (events from earlier commands are skipped)."""
    while True:
        msg = json.loads(ws.recv(timeout=timeout))
        if msg.get("type") != "event":
            return msg


# --- the reported cases, one by one ----------------------------------------------------------------------------


@pytest.mark.parametrize("depth", [1_000, 5_000, 200_000])
def test_deep_nesting_is_a_4xx_on_every_body_route(server, depth):
    for method, path in _routes(server.node):
        for body in ("[" * depth + "]" * depth, '{"a":' * depth + "1" + "}" * depth):
            r = server.http.request(
                method, path, content=body.encode(), headers={"content-type": "application/json"}
            )
            SENT["rest"] += 1
            assert r.status_code in (400, 413), (path, r.status_code, r.text[:200])
            _check_response(server, r)


def test_bare_nan_and_nan_fields_are_4xx_that_serialise(server):
    for path, body in [
        ("/api/inputs/arousal", b"NaN"),
        ("/api/inputs/arousal", b'{"value": NaN}'),
        ("/api/inputs/arousal", b'{"value": 1e999}'),
        ("/api/previz/ghost", b'{"visible": NaN}'),
        ("/api/previz/ghost", b"NaN"),
        ("/api/inputs/arousal", b'{"value": Infinity}'),
    ]:
        r = server.http.put(path, content=body, headers={"content-type": "application/json"})
        SENT["rest"] += 1
        assert 400 <= r.status_code < 500 and r.json()["detail"]["code"] == "non_finite", (path, body, r.text)
        _check_response(server, r)


def test_lone_surrogates_are_rejected_and_never_kill_a_socket(server, control_socket):
    for body in (b'{"type": "\\ud800"}', b'{"type": "say", "text": "\\udfff hi"}', b'{"\\ud800": 1}'):
        r = server.http.post("/api/commands", content=body, headers={"content-type": "application/json"})
        SENT["rest"] += 1
        assert r.status_code == 400 and r.json()["detail"]["code"] == "invalid_unicode", r.text
        control_socket.send(body.decode())
        SENT["ws"] += 1
        err = _reply(control_socket)
        assert err["type"] == "error" and err["code"] == "invalid_unicode"
    control_socket.send(
        json.dumps({"id": "still-open", "type": "set_emotion", "valence": 0.0, "arousal": 0.0})
    )
    assert _reply(control_socket)["id"] == "still-open"
    server.state = _state(server.http)


def test_binary_messages_are_answered_on_every_websocket(server):
    for path in ("/ws/control", "/ws/telemetry", "/ws/frames"):
        with ws_connect(f"ws://127.0.0.1:{server.port}{path}", max_size=None) as ws:
            ws.send(b"\x00\xffbinary")
            SENT["ws"] += 1
            while True:
                msg = ws.recv(timeout=30)
                if isinstance(msg, str) and json.loads(msg).get("type") == "error":
                    break
            assert json.loads(msg)["code"] == "binary_message"
            ws.send(b"again")  # the socket is still open and still answering
            SENT["ws"] += 1
            while True:
                msg = ws.recv(timeout=30)
                if isinstance(msg, str) and json.loads(msg).get("type") == "error":
                    break


def test_library_writes_are_validated_before_anything_is_stored(server):
    http, postures = server.http, server.robot / "postures"
    junk = {"values": {"head_yaw": [[[[[[{"a": [1, 2, 3]}]]]]]]}, "padding": ["x" * 50] * 100}
    for kind, doc in [
        ("postures", junk),
        ("postures", {"name": "x", "values": {"head_yaw": 99.0}}),
        ("postures", {"values": {"no_such_dof": 0.1}}),
        ("postures", {"values": {}}),
        ("postures", {"head_yaw": 0.1}),
        ("clips", {"tracks": {"no_such_dof": [{"t": 0, "v": 0}]}}),
        ("clips", junk),
        ("programs", junk),
    ]:
        r = http.put(f"/api/{kind}/stored", json=doc)
        SENT["rest"] += 1
        assert r.status_code == 422, (kind, doc, r.text)
        assert not (server.robot / kind / "stored.json").exists()
    good = {"name": "lean", "values": {"head_yaw": 0.3, "mouth": "smile", "eye_leds": [1, 0.5, 0]}}
    assert http.put("/api/postures/lean", json=good).json() == {"saved": "lean"}
    stored = json.loads((postures / "lean.json").read_text())
    assert stored["values"] == good["values"] and stored["format"] == "nutty-posture/1"
    assert http.get("/api/postures/lean").json()["values"]["head_yaw"] == 0.3
    builtin = http.get("/api/postures/happy").json()  # a GET/PUT round trip of a built-in posture
    assert http.put("/api/postures/happy2", json=builtin).status_code == 200
    assert http.delete("/api/postures/lean").status_code == 200
    assert http.delete("/api/postures/happy2").status_code == 200


def test_a_chunked_body_is_stopped_at_the_limit_with_413(server):
    """11 MB of chunked body (no Content-Length): the server answers 413 once it has read 1 MB, while
    the body is still incomplete; before, it read everything and only then answered."""
    with socket.create_connection(("127.0.0.1", server.port), timeout=30) as s:
        s.sendall(
            b"POST /api/commands HTTP/1.1\r\nHost: 127.0.0.1:%d\r\nContent-Type: application/json\r\n"
            b"Transfer-Encoding: chunked\r\n\r\n" % server.port
        )
        chunk = b"[" + b"1," * 32_000 + b"1]"
        sent = 0
        try:
            while sent <= 1_000_000:  # just past the limit, far from 11 MB, and never the final chunk
                s.sendall(b"%x\r\n%s\r\n" % (len(chunk), chunk))
                sent += len(chunk)
        except OSError:  # the server may already have answered and closed
            pass
        SENT["rest"] += 1
        response = b""
        while b"\r\n\r\n" not in response:
            data = s.recv(65536)
            if not data:
                break
            response += data
    assert response.startswith(b"HTTP/1.1 413"), response[:200]
    assert b'"too_large"' in response or b"\r\n\r\n" in response


def test_a_declared_oversized_body_is_refused_before_reading(server):
    r = server.http.post(
        "/api/commands", content=b"x" * 1_000_001, headers={"content-type": "application/json"}
    )
    SENT["rest"] += 1
    assert r.status_code == 413 and r.json()["detail"]["code"] == "too_large"
    _check_response(server, r)


def test_wrong_types_name_the_field(server):
    for path, body, field in [
        ("/api/inputs/arousal", {"value": "loud"}, "arousal"),
        ("/api/inputs/arousal", {"volume": 1}, "value"),
        ("/api/previz/ghost", {"visible": [1]}, "visible"),
        ("/api/commands", {"type": "set_led", "colour": "red"}, "colour"),
    ]:
        r = server.http.request("POST" if path.endswith("commands") else "PUT", path, json=body)
        SENT["rest"] += 1
        assert r.status_code == 422 and r.json()["detail"]["field"] == field, r.text
        _check_response(server, r)

"""`nutty mcp` against a real `nutty serve`, driven by the official MCP SDK's client: over stdio with
the initialize handshake (as today's desktop clients speak it), and over streamable HTTP with the
2026 protocol (subscriptions/listen). The tools, their enums and their errors are the server's."""

from __future__ import annotations

import asyncio
import json
import os
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

import httpx
import mcp
import mcp_types as types
import pytest
from mcp import StdioServerParameters

from backend.engine.embodiment import robots_dir
from tests.server_process import free_port, server_process, stop_process
from tests.tool_calls import example_arguments

TIMEOUT = 30.0  # s: generous bounds on waits, never asserted as timings
DOCUMENTED_URL = "http://127.0.0.1:8000"  # the server URL docs/ai.md configures


def clip_doc(name: str) -> dict:
    return {
        "format": "nutty-clip/1",
        "name": name,
        "description": f"{name}: a quick look left and back.",
        "relative": True,
        "tracks": {"head_yaw": [{"t": 0, "v": 0}, {"t": 0.3, "v": 0.25}, {"t": 0.6, "v": 0}]},
    }


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    """`nutty serve` on a copy of the default robot (its interactive program), so clips saved by the
    tests never touch the repository."""
    folder = tmp_path_factory.mktemp("robot") / "nutty_desk"
    shutil.copytree(robots_dir() / "nutty_desk", folder)
    with server_process("--robot", str(folder), "--no-previz") as srv:
        srv.folder = folder
        yield srv


def mcp_command(*args: str) -> list[str]:
    return [sys.executable, "-m", "backend.cli", "mcp", *args]


def documented_config(url: str) -> StdioServerParameters:
    """The MCP client configuration of docs/ai.md, as a client would start it: `nutty` is this
    checkout's CLI, and the URL is the test server's."""
    text = (Path(__file__).resolve().parents[1] / "docs" / "ai.md").read_text()
    block = text.split("<!-- mcp-config -->", 1)[1].split("```json", 1)[1].split("```", 1)[0]
    entry = json.loads(block)["mcpServers"]["nutty"]
    assert entry["command"] == "nutty" and entry["args"][:2] == ["mcp", "--url"]
    command = mcp_command(*[url if a == DOCUMENTED_URL else a for a in entry["args"][1:]])
    return StdioServerParameters(
        command=command[0], args=command[1:], env={**os.environ, **entry.get("env", {})}
    )


def text_of(result: types.CallToolResult) -> str:
    return "\n".join(c.text for c in result.content if isinstance(c, types.TextContent))


def test_the_documented_client_lists_plays_waits_cancels_and_sees_the_tools_change(server):
    async def main() -> None:
        changed = asyncio.Event()

        async def on_message(message) -> None:
            if getattr(message, "method", None) == "notifications/tools/list_changed":
                changed.set()

        params = documented_config(server.url)
        async with mcp.Client(params, mode="legacy", message_handler=on_message) as client:
            tools = {t.name: t for t in (await client.list_tools()).tools}
            assert {
                "play_clip",
                "set_posture",
                "look_at",
                "set_emotion",
                "say",
                "set_led",
                "set_face",
                "stop",
                "cancel",
                "get_status",
            } <= set(tools)
            clips = sorted(p.stem for p in (server.folder / "clips").glob("*.json"))
            assert tools["play_clip"].input_schema["properties"]["clip"]["enum"] == clips

            done = await client.call_tool("play_clip", {"clip": "nod", "wait": True, "timeout": TIMEOUT})
            assert not done.is_error and done.structured_content["status"] == "completed"
            assert text_of(done).startswith("play_clip: completed")

            running = await client.call_tool("play_clip", {"clip": "sad"})
            cid = running.structured_content["id"]
            assert running.structured_content["status"] == "started"
            cancelled = await client.call_tool("cancel", {"target": cid})
            assert cancelled.structured_content["result"] == {"target": cid, "status": "cancelled"}
            polled = await client.call_tool("get_status", {"id": cid, "wait": True, "timeout": TIMEOUT})
            assert polled.structured_content["command"]["status"] == "cancelled"

            bad = await client.call_tool("play_clip", {"clip": "moonwalk"})
            assert bad.is_error and "field 'clip'" in text_of(bad) and "'nod'" in text_of(bad)
            assert bad.structured_content["error"]["field"] == "clip"
            bad = await client.call_tool("set_emotion", {"valence": 2, "arousal": 0})
            assert bad.is_error and bad.structured_content["error"]["field"] == "valence"

            for name, tool in tools.items():  # a generated call of every tool executes
                result = await client.call_tool(name, example_arguments(tool.input_schema))
                assert result.is_error == (name == "cancel"), (name, text_of(result))  # cancel: an unknown id

            async with httpx.AsyncClient(base_url=server.url) as http:
                assert (await http.put("/api/clips/peek", json=clip_doc("peek"))).status_code == 200
            await asyncio.wait_for(changed.wait(), TIMEOUT)
            tools = {t.name: t for t in (await client.list_tools()).tools}
            assert "peek" in tools["play_clip"].input_schema["properties"]["clip"]["enum"]
            played = await client.call_tool("play_clip", {"clip": "peek", "wait": True, "timeout": TIMEOUT})
            assert played.structured_content["status"] == "completed"

            library = await client.read_resource("nutty://library")
            assert '"peek"' in library.contents[0].text

            behaviours = sorted(p.stem for p in (server.folder / "behaviours").glob("*.json"))
            assert tools["play_behaviour"].input_schema["properties"]["behaviour"]["enum"] == behaviours
            changed.clear()
            quick = {
                "description": "A nod and a word.",
                "tracks": [
                    {
                        "name": "t",
                        "items": [
                            {"id": "n", "kind": "play_clip", "clip": "nod"},
                            {"id": "s", "kind": "say", "text": "yes"},
                        ],
                    }
                ],
            }
            async with httpx.AsyncClient(base_url=server.url) as http:
                assert (await http.put("/api/behaviours/yes_nod", json=quick)).status_code == 200
            await asyncio.wait_for(changed.wait(), TIMEOUT)
            tools = {t.name: t for t in (await client.list_tools()).tools}
            assert "yes_nod" in tools["play_behaviour"].input_schema["properties"]["behaviour"]["enum"]
            played = await client.call_tool(
                "play_behaviour", {"behaviour": "yes_nod", "wait": True, "timeout": TIMEOUT}
            )
            assert played.structured_content["status"] == "completed", text_of(played)

    asyncio.run(main())


def wait_for_port(port: int, proc: subprocess.Popen, timeout: float = 60.0) -> None:
    deadline = time.time() + timeout
    while time.time() < deadline:
        assert proc.poll() is None, proc.stdout.read() if proc.stdout else "nutty mcp exited"
        with socket.socket() as s:
            if s.connect_ex(("127.0.0.1", port)) == 0:
                return
        time.sleep(0.2)
    raise RuntimeError("nutty mcp --http did not start")


def test_streamable_http_client_with_subscriptions(server):
    port = free_port()
    proc = subprocess.Popen(
        mcp_command("--url", server.url, "--http", str(port)),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        wait_for_port(port, proc)

        async def main() -> None:
            async with mcp.Client(f"http://127.0.0.1:{port}/mcp") as client:
                tools = {t.name: t for t in (await client.list_tools()).tools}
                assert "wave" in tools["play_clip"].input_schema["properties"]["clip"]["enum"]
                robot = await client.read_resource("nutty://robot")
                assert '"nutty_desk"' in robot.contents[0].text
                async with client.listen(tools_list_changed=True) as events:
                    async with httpx.AsyncClient(base_url=server.url) as http:
                        assert (
                            await http.put("/api/clips/glance", json=clip_doc("glance"))
                        ).status_code == 200
                    await asyncio.wait_for(events.__anext__(), TIMEOUT)
                tools = {t.name: t for t in (await client.list_tools()).tools}
                assert "glance" in tools["play_clip"].input_schema["properties"]["clip"]["enum"]
                first = await client.call_tool("play_clip", {"clip": "sad"})
                second = await client.call_tool("play_clip", {"clip": "glance", "if_busy": "reject"})
                assert second.is_error and second.structured_content["error"]["code"] == "busy"
                assert first.structured_content["id"] in text_of(second)
                stopped = await client.call_tool("stop", {"layer": "gesture"})
                assert stopped.structured_content["command"] == "stop_clip"

        asyncio.run(main())
    finally:
        stop_process(proc)


def test_an_unreachable_server_is_a_tool_error_not_a_crash():
    from backend.mcp_bridge import Remote, create_server

    server, _ = create_server(Remote(f"http://127.0.0.1:{free_port()}"))  # nothing listens there

    async def main() -> None:
        async with mcp.Client(server, mode="legacy") as client:  # in process, the SDK's memory transport
            result = await client.call_tool("play_clip", {"clip": "nod"})
            assert result.is_error and "did not answer" in text_of(result)
            assert result.structured_content["error"]["code"] == "unreachable"

    asyncio.run(main())


@pytest.mark.parametrize(
    "args, fragment", [(["--url", "ftp://robot"], "--url"), (["--http", "70000"], "--http")]
)
def test_bad_command_line_is_refused(capsys, args, fragment):
    from backend.cli import main

    assert main(["mcp", *args]) == 2
    assert fragment in capsys.readouterr().err


def test_stdio_answers_every_line_and_goes_on_working():
    """A line that is not JSON, NaN, Infinity, a lone surrogate, deep nesting, a duplicate key and a
    message that is no JSON-RPC each get a JSON-RPC error (the field named where there is one), and
    the session still answers a handshake afterwards. No server is needed for any of this."""
    proc = subprocess.Popen(
        mcp_command("--url", f"http://127.0.0.1:{free_port()}"),
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
        encoding="utf-8",
        errors="surrogatepass",
    )

    def ask(line: str) -> dict:
        proc.stdin.write(line + "\n")
        proc.stdin.flush()
        return json.loads(proc.stdout.readline())  # (a hang fails the test by the suite's timeout)

    call = '{"jsonrpc": "2.0", "id": %d, "method": "tools/call", "params": {"name": "set_emotion", "arguments": %s}}'
    try:
        bad = ask("this is not json")
        assert bad["error"]["code"] == -32700 and bad["id"] is None
        nan = ask(call % (2, '{"valence": NaN, "arousal": 0}'))
        assert nan["id"] == 2 and nan["error"]["code"] == -32602
        assert (
            nan["error"]["data"]["field"] == "params.arguments.valence" and "NaN" in nan["error"]["message"]
        )
        inf = ask(call % (3, '{"valence": 0, "arousal": -Infinity}'))
        assert (
            inf["id"] == 3
            and inf["error"]["code"] == -32602
            and "infinity" in inf["error"]["message"].lower()
        )
        sur = ask(call % (4, '{"valence": 0, "arousal": 0, "note": "\\ud800"}'))
        assert sur["id"] == 4 and sur["error"]["data"]["field"] == "params.arguments.note"
        deep = ask(call % (5, "[" * 5000 + "]" * 5000))
        assert deep["id"] == 5 and deep["error"]["data"] == {"field": "params.arguments", "code": "too_deep"}
        dup = ask('{"jsonrpc": "2.0", "id": 6, "id": 7, "method": "ping"}')
        assert dup["error"]["data"] == {"field": "id", "code": "duplicate_key"}
        odd = ask('{"jsonrpc": "2.0", "id": 8}')
        assert odd["id"] == 8 and odd["error"]["code"] == -32600
        hello = ask(
            json.dumps(
                {
                    "jsonrpc": "2.0",
                    "id": 9,
                    "method": "initialize",
                    "params": {
                        "protocolVersion": "2025-06-18",
                        "capabilities": {},
                        "clientInfo": {"name": "t", "version": "1"},
                    },
                }
            )
        )
        assert hello["id"] == 9 and hello["result"]["serverInfo"]["name"] == "nutty"
    finally:
        proc.stdin.close()
        stop_process(proc)

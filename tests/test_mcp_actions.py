"""`nutty mcp` as an agent uses long actions, driven by the official MCP SDK's client against a real
`nutty serve`: annotations on every tool, progress notifications while a waited clip plays, a status
resource that announces its updates, the robot_brief prompt, and the HTTP transport behind the token."""

from __future__ import annotations

import asyncio
import shutil
import subprocess

import httpx
import httpx2
import mcp
import pytest
from mcp.client.streamable_http import streamable_http_client

from backend.engine.embodiment import robots_dir
from tests.server_process import free_port, server_process, stop_process
from tests.test_mcp import TIMEOUT, mcp_command, wait_for_port

TOKEN = "mcp-test-token"


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    folder = tmp_path_factory.mktemp("robot") / "nutty_desk"
    shutil.copytree(robots_dir() / "nutty_desk", folder)
    with server_process("--robot", str(folder), "--no-previz", "--token", TOKEN) as srv:
        yield srv


def _stdio(server) -> mcp.StdioServerParameters:
    cmd = mcp_command("--url", server.url, "--token", TOKEN)
    return mcp.StdioServerParameters(command=cmd[0], args=cmd[1:])


def test_annotations_progress_status_updates_and_the_prompt(server):
    async def main() -> None:
        updates: list[str] = []

        async def on_message(message) -> None:
            if getattr(message, "method", None) == "notifications/resources/updated":
                updates.append(str(message.params.uri))

        async with mcp.Client(_stdio(server), mode="legacy", message_handler=on_message) as client:
            tools = {t.name: t for t in (await client.list_tools()).tools}
            assert all(t.annotations is not None for t in tools.values())
            assert tools["get_status"].annotations.read_only_hint is True
            assert tools["play_clip"].annotations.idempotent_hint is False
            assert tools["set_posture"].annotations.idempotent_hint is True
            assert tools["cancel"].annotations.destructive_hint is True
            assert "request_id" in tools["play_clip"].input_schema["properties"]

            await client.subscribe_resource("nutty://status")
            progress: list[float] = []

            async def on_progress(value: float, total: float | None, message: str | None) -> None:
                progress.append(value / (total or 1.0))

            done = await client.call_tool(
                "play_clip", {"clip": "sad", "wait": True, "timeout": TIMEOUT}, progress_callback=on_progress
            )
            assert not done.is_error and done.structured_content["status"] == "completed"
            assert done.structured_content["waited"] is True
            assert len(progress) >= 3 and progress == sorted(progress)  # it moved forward, in steps
            assert progress[-1] == 1.0 and 0.0 < progress[len(progress) // 2] < 1.0
            for _ in range(50):  # the notification may trail the call's answer by a moment
                if "nutty://status" in updates:
                    break
                await asyncio.sleep(0.1)
            assert "nutty://status" in updates

            prompts = (await client.list_prompts()).prompts
            assert [p.name for p in prompts] == ["robot_brief"]
            brief = await client.get_prompt("robot_brief")
            text = brief.messages[0].content.text
            assert "nutty_desk" in text and "head_yaw" in text and "sad" in text and "happy" in text
            assert "request_id" in text

    asyncio.run(main())


def test_http_transport_asks_for_the_token(server):
    port = free_port()
    proc = subprocess.Popen(
        mcp_command("--url", server.url, "--token", TOKEN, "--http", str(port)),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        wait_for_port(port, proc)
        url = f"http://127.0.0.1:{port}/mcp"
        hello = {"jsonrpc": "2.0", "id": 1, "method": "ping"}
        refused = httpx.post(url, json=hello, headers={"Accept": "application/json, text/event-stream"})
        assert refused.status_code == 401
        wrong = httpx.post(url, json=hello, headers={"Authorization": "Bearer nope"})
        assert wrong.status_code == 401

        async def main() -> None:
            auth = httpx2.AsyncClient(headers={"Authorization": f"Bearer {TOKEN}"})
            async with mcp.Client(streamable_http_client(url, http_client=auth)) as client:
                tools = {t.name for t in (await client.list_tools()).tools}
                assert "play_clip" in tools

        asyncio.run(main())
    finally:
        stop_process(proc)

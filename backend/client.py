"""A small Python client for AIs and scripts driving a Nutty server over REST.

    from backend.client import NuttyClient
    robot = NuttyClient("http://127.0.0.1:8000")
    robot.play("wave", layer="gesture")
    robot.look_at(0.6, 0.2, 0.35)
    robot.set(arousal=0.5)
    robot.say("Hello!")
    robot.call_tool("play_clip", clip="nod", wait=True)  # the AI tools (GET /api/tools), see docs/ai.md

Every method returns the server's JSON; errors raise NuttyError with the server's code and message.
"""

from __future__ import annotations

from typing import Any

import httpx


class NuttyError(RuntimeError):
    def __init__(self, status: int, detail: Any):
        self.status = status
        self.detail = detail
        message = detail.get("message") if isinstance(detail, dict) else str(detail)
        code = detail.get("code") if isinstance(detail, dict) else None
        self.code = code
        super().__init__(f"{status} {code or ''}: {message}".strip())


class NuttyClient:
    def __init__(
        self,
        url: str = "http://127.0.0.1:8000",
        token: str | None = None,
        timeout: float = 5.0,
        transport: Any = None,
    ):
        headers = {"Authorization": f"Bearer {token}"} if token else {}
        kw = {"transport": transport} if transport is not None else {}
        self._http = httpx.Client(base_url=url.rstrip("/"), headers=headers, timeout=timeout, **kw)

    def close(self) -> None:
        self._http.close()

    def __enter__(self) -> NuttyClient:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def _call(self, method: str, path: str, **kw: Any) -> Any:
        r = self._http.request(method, path, **kw)
        if r.status_code >= 400:
            try:
                detail = r.json().get("detail")
            except ValueError:
                detail = r.text
            raise NuttyError(r.status_code, detail)
        return r.json() if r.content else None

    # --- commands --------------------------------------------------------------------------------
    def command(self, type: str, **fields: Any) -> dict[str, Any]:
        """Send any command of the union (see GET /api/schema/commands)."""
        return self._call("POST", "/api/commands", json={"type": type, **fields})

    def play(self, clip: str, layer: str | None = None, **kw: Any) -> dict[str, Any]:
        return self.command("play_clip", clip=clip, layer=layer, **kw)

    def stop_clip(self, layer: str | None = None) -> dict[str, Any]:
        return self.command("stop_clip", layer=layer)

    def posture(self, name: str, duration: float | None = None) -> dict[str, Any]:
        return self.command("go_posture", posture=name, duration=duration)

    def look_at(self, x: float, y: float, z: float) -> dict[str, Any]:
        return self.command("set_gaze", target=[x, y, z])

    def behaviour(self, name: str, if_busy: str | None = None, **params: Any) -> dict[str, Any]:
        """Play one of the robot's behaviours with these parameters (`play_behaviour`)."""
        extra = {"if_busy": if_busy} if if_busy else {}
        return self.command("play_behaviour", behaviour=name, params=params, **extra)

    def say(self, text: str) -> dict[str, Any]:
        return self.command("say", text=text)

    def sound(self, name: str) -> dict[str, Any]:
        return self.command("play_sound", sound=name)

    def led(self, r: float, g: float, b: float, dof: str | None = None) -> dict[str, Any]:
        return self.command("set_led", colour=[r, g, b], dof=dof)

    def face(self, expression: str) -> dict[str, Any]:
        return self.command("set_face", expression=expression)

    def emotion(self, valence: float, arousal: float) -> dict[str, Any]:
        return self.command("set_emotion", valence=valence, arousal=arousal)

    def layer(self, name: str, active: bool = True, fade: float | None = None) -> dict[str, Any]:
        return self.command("set_layer", layer=name, active=active, fade=fade)

    def set(self, **inputs: Any) -> dict[str, Any]:
        """Set exposed inputs of the running program at the same tick."""
        return self.command("set_inputs", values=inputs)

    def reset(self) -> dict[str, Any]:
        return self.command("reset")

    def stop_all(self) -> dict[str, Any]:
        return self.command("stop_all")

    def cancel(self, command_id: str) -> dict[str, Any]:
        return self._call("DELETE", f"/api/commands/{command_id}")

    # --- tools for AIs (docs/ai.md) ----------------------------------------------------------------
    def tools(self, format: str = "plain") -> Any:
        """The tools generated for the running robot and program (plain, openai or anthropic)."""
        return self._call("GET", "/api/tools", params={"format": format})

    def call_tool(self, name: str, **arguments: Any) -> dict[str, Any]:
        """Carry out one tool call, e.g. `call_tool("play_clip", clip="nod", wait=True)`."""
        wait = float(arguments.get("timeout", 30.0)) if arguments.get("wait") else 0.0
        return self._call("POST", f"/api/tools/{name}", json=arguments, **self._waiting(wait))

    def _waiting(self, seconds: float) -> dict[str, Any]:
        """Request options that let an answer take `seconds` longer than the client's read timeout
        (a tool call that waits for its action's end)."""
        read = self._http.timeout.read
        return {"timeout": read + seconds} if read is not None and seconds > 0 else {}

    # --- state -------------------------------------------------------------------------------------
    def status(self) -> dict[str, Any]:
        return self._call("GET", "/api/status")

    def robot(self) -> dict[str, Any]:
        return self._call("GET", "/api/robot")

    def program(self) -> dict[str, Any]:
        return self._call("GET", "/api/program")

    def load_program(self, program: dict[str, Any]) -> dict[str, Any]:
        return self._call("PUT", "/api/program", json=program)

    def tune(self, node: str, **params: Any) -> dict[str, Any]:
        """Change a node's parameters live (no rebuild)."""
        return self._call("PATCH", f"/api/program/nodes/{node}/params", json=params)

"""Tools for AIs, generated from the command registry and the running robot, program and library.

`build_tools(session)` gives the tools the running program can carry out (each command class declares its
own, `ai_tool`, and backend.tools.table gathers them from the command registry; the argument schemas
come from the command models, the enums from the live library and program);
`render(toolset, format)` writes them for a function-calling dialect (plain, openai, anthropic);
`call_tool(hub, name, arguments)` carries one out through the server's one command path; `robot_status`
says what the robot is doing. Served as `GET /api/tools` and `POST /api/tools/{name}`; `nutty mcp`
offers the same tools over the Model Context Protocol.
"""

from backend.tools.build import Tool, ToolSet, build_tools
from backend.tools.dialects import FORMATS, render
from backend.tools.errors import ToolError
from backend.tools.status import robot_status

__all__ = ["FORMATS", "Tool", "ToolError", "ToolSet", "build_tools", "render", "robot_status"]

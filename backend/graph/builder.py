"""A small fluent builder for Animation Programs in Python (tests, `nutty new`, examples).

b = ProgramBuilder("wave")
sine = b.node("sine", dofs=["head_yaw"], amplitude=0.3)
b.connect(sine, b.output())
program = b.build()
"""

from __future__ import annotations

from typing import Any

from backend.graph.schema import FORMAT, Program


class ProgramBuilder:
    def __init__(
        self,
        name: str = "untitled",
        description: str = "",
        robot: str | None = None,
        rate: float | None = None,
        max_level: int = 3,
    ):
        self.doc: dict[str, Any] = {
            "format": FORMAT,
            "name": name,
            "description": description,
            "max_level": max_level,
            "inputs": [],
            "nodes": [],
            "edges": [],
        }
        if robot:
            self.doc["robot"] = robot
        if rate:
            self.doc["rate"] = rate
        self._count: dict[str, int] = {}
        self._output: str | None = None

    def node(
        self, type_name: str, node_id: str | None = None, ui: dict[str, Any] | None = None, **params: Any
    ) -> str:
        """Add a node and return its id (default: the type name with a counter)."""
        if node_id is None:
            k = self._count.get(type_name, 0) + 1
            self._count[type_name] = k
            node_id = type_name if k == 1 else f"{type_name}_{k}"
        n = len(self.doc["nodes"])
        self.doc["nodes"].append(
            {"id": node_id, "type": type_name, "params": params, "ui": ui or {"x": 260.0 * n, "y": 0.0}}
        )
        return node_id

    def output(self) -> str:
        if self._output is None:
            self._output = self.node("output", "output")
        return self._output

    def connect(self, src: str, dst: str, src_port: str = "out", dst_port: str = "in") -> ProgramBuilder:
        self.doc["edges"].append(
            {"from": {"node": src, "port": src_port}, "to": {"node": dst, "port": dst_port}}
        )
        return self

    def chain(self, *nodes: str) -> ProgramBuilder:
        """Connect frame ports out -> in along `nodes`; the output node takes its `in` port."""
        for a, b in zip(nodes, nodes[1:]):
            self.connect(a, b)
        return self

    def expose(self, name: str, type: str = "float", default: Any = None, **kw: Any) -> str:
        self.doc["inputs"].append({"name": name, "type": type, "default": default, **kw})
        return self.node("input", f"in_{name}", name=name, type=type)

    def build(self) -> Program:
        return Program.model_validate(self.doc)

    def to_dict(self) -> dict[str, Any]:
        return self.build().to_json_dict()

"""What the program checks report: an `Issue` (one error or warning) and the `ValidationReport`.

The codes and what they mean are in ERROR_CODES and WARNING_CODES (and docs/program-format.md, which
a test keeps in step). `port` is an input/output port name for graph errors (edges, missing inputs)
and the parameter path relative to the node's `params` for parameter errors (`amplitude`, `dofs`,
`layers[1].mask`); `path` goes down to the offending element (`nodes[3].params.layers[1].mask[0]`).
"""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field

ERROR_CODES: dict[str, str] = {
    "malformed_json": "the text is not valid JSON (line and column given)",
    "wrong_format": "the `format` field is missing or names another version of the format",
    "schema": "a field of the document has the wrong shape (missing, wrong type, unexpected)",
    "duplicate_node": "two nodes share an id",
    "unknown_block_type": "a node's `type` is not a registered block",
    "unknown_param": "a node sets a parameter its block does not have",
    "invalid_param": "a parameter value is out of range or of the wrong type",
    "unknown_dof": "a DoF selector names a DoF the robot does not have (or is malformed)",
    "block_config": "the block rejects its parameters as a whole (e.g. an unknown posture)",
    "unknown_node": "an edge names a node that does not exist",
    "unknown_port": "an edge names a port its node does not have",
    "port_type_mismatch": "an edge joins ports of incompatible types",
    "multiple_edges": "more than one edge goes into the same input",
    "missing_input": "a required input has no edge",
    "cycle": "edges form a loop",
    "no_output": "the program has no `output` node",
    "multiple_outputs": "the program has more than one `output` node",
    "level_too_high": "the graph needs a higher APU level than the program or engine allows",
    "unknown_exposed_input": "an `input` node reads an exposed input the program does not declare",
    "duplicate_input": "two exposed inputs share a name",
    "invalid_input": "an exposed input's declaration is inconsistent (range, default)",
    "unknown_subgraph": "a `subgraph` node names a subgraph the program does not define",
    "subgraph_cycle": "a subgraph contains itself (directly or through other subgraphs)",
    "unknown_exposed_port": "a subgraph exposes a port of a node it does not have, or an edge uses a port a "
    "subgraph node does not expose",
}
WARNING_CODES: dict[str, str] = {
    "unconnected_node": "a node does not feed the output",
    "zero_weight_layer": "a layer of a mixer has weight 0",
    "empty_layer": "a layer of a mixer has nothing connected",
    "unused_input": "an exposed input is read by no node",
}


# Serialised, every field is present (None when unset): the editor's generated types say so.
_ALWAYS_SERIALISED = ConfigDict(json_schema_serialization_defaults_required=True)


class Issue(BaseModel):
    """One validation error or warning."""

    model_config = _ALWAYS_SERIALISED

    code: str
    node: str | None = None
    port: str | None = None
    message: str
    path: str | None = Field(
        default=None, description="JSON path in the document, e.g. nodes[2].params.amplitude"
    )
    line: int | None = None
    column: int | None = None

    def render(self) -> str:
        """`[code] node.port: message` (with line and column for JSON errors)."""
        where = ".".join(x for x in (self.node, self.port) if x)
        at = ""
        if self.line is not None and f"line {self.line}" not in self.message:
            at = f" (line {self.line}, column {self.column})"
        return f"[{self.code}] {where + ': ' if where else ''}{self.message}{at}"


class ValidationReport(BaseModel):
    model_config = _ALWAYS_SERIALISED

    valid: bool
    level: int | None = None
    errors: list[Issue] = Field(default_factory=list)
    warnings: list[Issue] = Field(default_factory=list)

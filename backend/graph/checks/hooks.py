"""What a block class's own checks see of the program, and how they report.

The check passes call two class hooks of every node's block (defaults: nothing to check):

- `Block.check(params, node)` once its parameters are valid and its ports known, before its DoFs are
  checked and it is configured. A node whose own check reports an error is not configured (one
  broken thing, one error).
- `Block.check_wiring(params, node)` once the program's edges are known (`node.connected(port)`).

`node` is a NodeCheck. Block modules use it by duck typing (they import nothing from backend.graph),
so the engine's blocks do not depend on the program format's checker.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from backend.engine.embodiment import Embodiment
from backend.graph.checks.state import CheckState
from backend.graph.checks.text import loc
from backend.graph.issues import ERROR_CODES, WARNING_CODES, Issue
from backend.graph.schema import ExposedInput, Node


class NodeCheck:
    """One node, as its block class's check hooks see it."""

    def __init__(self, state: CheckState, node: Node, index: int):
        self._state = state
        self.node_id = node.id
        self.type_name = node.type
        self.index = index  # the node's place in the document's `nodes`
        self.failed = False  # an error was reported
        self.ports_in_doubt = False  # an error makes the node's ports uncertain: skip its edges

    @property
    def embodiment(self) -> Embodiment:
        return self._state.embodiment

    # --- the program's exposed inputs -------------------------------------------------------------
    @property
    def exposed_inputs(self) -> Mapping[str, ExposedInput]:
        """The exposed inputs the program declares (well-formed ones), by name."""
        return self._state.declared

    @property
    def broken_inputs(self) -> frozenset[str]:
        """Names of exposed inputs whose declaration is malformed (already reported as schema errors)."""
        return frozenset(self._state.malformed_inputs)

    def read_input(self, name: str) -> ExposedInput | None:
        """Note that this node reads exposed input `name`; its declaration, or None if undeclared."""
        self._state.read_inputs.add(name)
        return self._state.declared.get(name)

    # --- edges (in check_wiring) ------------------------------------------------------------------
    def connected(self, port: str) -> bool:
        """Whether an edge goes into this node's input `port`."""
        return (self.node_id, port) in self._state.incoming

    # --- reporting --------------------------------------------------------------------------------
    def error(
        self,
        code: str,
        message: str,
        *,
        port: str | None = None,
        at: tuple[Any, ...] | None = None,
        ports_in_doubt: bool = False,
    ) -> None:
        """Report an error; `at` is the path inside the node's `params` (None: the node itself).

        `ports_in_doubt`: the error is about something the node's ports depend on, so the edges
        touching it are not checked against them (no knock-on errors).
        """
        if code not in ERROR_CODES:
            raise ValueError(f"unknown error code {code!r}: add it to ERROR_CODES and docs/program-format.md")
        self._state.errors.append(
            Issue(code=code, node=self.node_id, port=port, path=self._path(at), message=message)
        )
        self.failed = True
        self.ports_in_doubt = self.ports_in_doubt or ports_in_doubt

    def warning(
        self, code: str, message: str, *, port: str | None = None, at: tuple[Any, ...] | None = None
    ) -> None:
        """Report a warning (it never makes the program invalid); `at` as for `error`."""
        if code not in WARNING_CODES:
            raise ValueError(
                f"unknown warning code {code!r}: add it to WARNING_CODES and docs/program-format.md"
            )
        self._state.warnings.append(
            Issue(code=code, node=self.node_id, port=port, path=self._path(at), message=message)
        )

    def _path(self, at: tuple[Any, ...] | None) -> str:
        return loc(("nodes", self.index) if at is None else ("nodes", self.index, "params", *at))

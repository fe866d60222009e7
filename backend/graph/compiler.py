"""Check an Animation Program against a robot, plan it, and build its APU: check, then build.

    report, plan = check_program(source, embodiment)   # every error at once; plan is None if any
    apu = plan.instantiate(embodiment, ctx)            # fresh blocks; call again for another APU

`check_program` runs the check passes of `backend.graph.checks` (each block class adds its own rules
through its `check` / `check_wiring` hooks) and, when they find no error, returns an immutable
`backend.graph.plan.Plan`. `compile_program` does both in one call and returns every error at once
(ComfyUI-style), each with a machine-readable code, the node id, the port or parameter it is about
(`port`), its exact place in the document (`path`) and a sentence for a person; plus warnings. A
program with errors produces no APU, so loading is atomic: nothing in a running engine changes.

One broken thing gives one error: a node whose type is unknown or whose parameters are invalid is
reported once, and edges touching it are checked only at their other end (no knock-on
`missing_input` or `unknown_node`).

The codes and what they mean are in ERROR_CODES and WARNING_CODES (and docs/program-format.md).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from backend.engine.apu import APU, MAX_LEVEL
from backend.engine.blocks.base import BlockContext, BlockParams
from backend.engine.embodiment import Embodiment
from backend.graph.checks import CheckState, run_checks
from backend.graph.issues import ERROR_CODES, WARNING_CODES, Issue, ValidationReport
from backend.graph.plan import Plan
from backend.graph.schema import Program

__all__ = [
    "ERROR_CODES",
    "WARNING_CODES",
    "CompileResult",
    "Issue",
    "Plan",
    "ProgramError",
    "ValidationReport",
    "check_program",
    "compile_or_raise",
    "compile_program",
]


@dataclass
class CompileResult:
    report: ValidationReport
    apu: APU | None = None
    program: Program | None = None  # the document (with its subgraphs, if any)
    params: dict[str, BlockParams] = field(default_factory=dict)  # by flat node id
    flat: Program | None = (
        None  # the document with its subgraphs flattened: the APU's nodes (ids `idle/breathe`)
    )

    @property
    def ok(self) -> bool:
        return self.apu is not None

    def compiled(self) -> Compiled | None:
        """The same result with every part present (None when the program did not compile)."""
        if self.apu is None or self.program is None or self.flat is None:
            return None
        return Compiled(self.report, self.apu, self.program, self.params, self.flat)


@dataclass(frozen=True)
class Compiled:
    """A program that compiled: its report (warnings), the APU, the document as sent, the parameters
    by flat node id and the flattened document."""

    report: ValidationReport
    apu: APU
    program: Program
    params: dict[str, BlockParams]
    flat: Program


class ProgramError(ValueError):
    """A program failed validation; `report` holds every error."""

    def __init__(self, report: ValidationReport):
        self.report = report
        first = report.errors[0] if report.errors else None
        more = f" (+{len(report.errors) - 1} more)" if len(report.errors) > 1 else ""
        super().__init__(f"{first.code}: {first.message}{more}" if first else "invalid program")


def _check(
    source: Any, embodiment: Embodiment, max_level: int, ctx: BlockContext | None, rate: float
) -> tuple[CheckState, ValidationReport, Plan | None]:
    state = run_checks(
        source, embodiment, max_level=max_level, ctx=ctx or BlockContext(embodiment=embodiment, rate=rate)
    )
    report = state.report()
    return state, report, Plan.from_checks(state) if report.valid else None


def check_program(
    source: Any,
    embodiment: Embodiment,
    *,
    max_level: int = MAX_LEVEL,
    ctx: BlockContext | None = None,
    rate: float = 100.0,
) -> tuple[ValidationReport, Plan | None]:
    """Check `source` (JSON text, bytes, a dict or a Program) for `embodiment`: the report, and the
    plan if the program is valid. Never raises for a bad program.

    Blocks are configured once against `ctx` (a new context at `rate` if None) to hear whether they
    accept their parameters on this robot; the plan keeps none of them.
    """
    _, report, plan = _check(source, embodiment, max_level, ctx, rate)
    return report, plan


def compile_program(
    source: Any,
    embodiment: Embodiment,
    *,
    max_level: int = MAX_LEVEL,
    ctx: BlockContext | None = None,
    rate: float = 100.0,
) -> CompileResult:
    """Validate `source` (JSON text, dict or Program) for `embodiment` and build its APU if valid.

    Never raises for a bad program: every problem is an Issue in the report.
    """
    ctx = ctx or BlockContext(embodiment=embodiment, rate=rate)
    state, report, plan = _check(source, embodiment, max_level, ctx, rate)
    if plan is None:
        return CompileResult(report, program=state.document, flat=state.program)
    params = {node.id: plan.params[node.id] for node in (plan.flat or plan.program).nodes}
    return CompileResult(
        report, apu=plan.instantiate(embodiment, ctx), program=plan.program, params=params, flat=plan.flat
    )


def compile_or_raise(source: Any, embodiment: Embodiment, **kw: Any) -> CompileResult:
    """Compile, raising ProgramError with the full report when the program is invalid."""
    result = compile_program(source, embodiment, **kw)
    if not result.ok:
        raise ProgramError(result.report)
    return result

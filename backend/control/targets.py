"""Where a command lands in the running program: its blocks, its layer mixers, its exposed inputs.

Every change happens in the clock thread (`engine.call`), so it lands at a tick boundary.
"""

from __future__ import annotations

from typing import Any

from backend.control.errors import CommandError
from backend.control.session_view import CommandSession
from backend.engine.blocks.base import Block, BlockCommandError, Role
from backend.engine.blocks.mixer import LayerMixer


def blocks_of(session: CommandSession, type_names: tuple[str, ...]) -> list[Block]:
    """The running program's blocks of these types, in program order ([] without a program)."""
    apu = session.engine.apu
    return [s.block for s in apu.steps if s.block.type_name in type_names] if apu else []


def mixers(session: CommandSession) -> list[LayerMixer]:
    """The running program's layer mixers (blocks with the mixer role)."""
    apu = session.engine.apu
    return [b for b in apu.blocks_of(Role.mixer) if isinstance(b, LayerMixer)] if apu else []


def upstream_of_layer(session: CommandSession, layer: str) -> set[str]:
    """Node ids whose output reaches the mixer input named `layer`."""
    apu = session.engine.apu
    if apu is None:
        return set()
    heads = [
        apu.steps[w.src].node_id
        for s in apu.steps
        if s.block.role.value == "mixer"
        for w in s.wires
        if w.port == layer
    ]
    seen: set[str] = set()
    stack = list(heads)
    while stack:
        nid = stack.pop()
        if nid in seen:
            continue
        seen.add(nid)
        stack.extend(apu.steps[w.src].node_id for w in apu.steps[apu.index[nid]].wires)
    return seen


def layer_members(session: CommandSession) -> dict[str, set[str]]:
    """Every mixer layer's name -> the node ids whose output reaches it."""
    apu = session.engine.apu
    if apu is None:
        return {}
    names = {w.port for s in apu.steps if s.block.role.value == "mixer" for w in s.wires}
    return {name: upstream_of_layer(session, name) for name in names}


def layers_of(session: CommandSession, node_id: str, members: dict[str, set[str]] | None = None) -> list[str]:
    """Names of the mixer layers whose chain holds node `node_id` (e.g. ['gesture']); `members`:
    `layer_members(session)` when it is at hand."""
    members = layer_members(session) if members is None else members
    return sorted(name for name, nodes in members.items() if node_id in nodes)


def find_block(
    session: CommandSession,
    type_names: tuple[str, ...],
    what: str,
    node: str | None = None,
    layer: str | None = None,
) -> Block:
    """The block named by `node`, else the one on `layer`, else the only one of these types.

    Raises CommandError `no_target` when there is none, `ambiguous_target` when several could be
    meant; `what` names the kind of block in the message ("clip player").
    """
    blocks = blocks_of(session, type_names)
    if node:
        found = [b for b in blocks if b.node_id == node]
        if not found:
            raise CommandError(
                f"the running program has no {what} with id '{node}'", field="node", code="no_target"
            )
        return found[0]
    if layer:
        ids = upstream_of_layer(session, layer)
        found = [b for b in blocks if b.node_id in ids]
        if not found:
            raise CommandError(
                f"the running program has no {what} on layer '{layer}'", field="layer", code="no_target"
            )
        return found[0]
    if len(blocks) == 1:
        return blocks[0]
    if not blocks:
        raise CommandError(f"the running program has no {what}", code="no_target")
    raise CommandError(
        f"the running program has {len(blocks)} {what}s ({[b.node_id for b in blocks]}); "
        f"name one with 'node' or 'layer'",
        field="node",
        code="ambiguous_target",
    )


def tell(session: CommandSession, block: Block, command: str, args: dict[str, Any]) -> Any:
    """Hand `command` to a block in the clock thread; its refusal becomes a CommandError `rejected` (or
    the refusal's own `code`, e.g. `busy`)."""

    try:
        return session.engine.call(lambda: block.handle(command, args))
    except BlockCommandError as exc:
        raise CommandError(str(exc), code=getattr(exc, "code", "rejected")) from exc


def declares_input(session: CommandSession, name: str) -> bool:
    """Whether the running program exposes an input called `name`."""
    return session.program is not None and session.program.input(name) is not None


def set_inputs(session: CommandSession, values: dict[str, Any]) -> dict[str, Any]:
    """Check every value first, then set them all at one tick: a rejected command changes nothing.

    Returns the values as set (coerced to each input's type); CommandError `invalid_input` names the
    first input that is not declared or whose value does not fit.
    """
    program = session.program
    out = {}
    for name, value in values.items():
        decl = program.input(name) if program is not None else None
        if decl is None:
            declared = [i.name for i in program.inputs] if program is not None else []
            raise CommandError(
                f"the running program has no exposed input '{name}' (declared: {declared})",
                field=name,
                code="invalid_input",
            )
        try:
            out[name] = decl.coerce(value)
        except (ValueError, TypeError, OverflowError) as exc:
            raise CommandError(str(exc), field=name, code="invalid_input") from exc
    session.engine.call(lambda: session.engine.ctx.inputs.update(out))
    return out

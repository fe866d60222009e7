"""EngineSession: one robot, one engine, the running program and everything that changes it.

The CLI (`nutty run`) and the server share this facade, so a program is validated, swapped, tuned
and fed inputs the same way everywhere. Every change is validated first and applied at a tick
boundary; a rejected change leaves the engine exactly as it was.
"""

from __future__ import annotations

import functools
import json
import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from backend import control
from backend.behaviours import validate_behaviour_doc
from backend.behaviours.player import BehaviourPlayer
from backend.engine.apu import MAX_LEVEL
from backend.engine.audio_events import stamp_audio
from backend.engine.blocks import BLOCKS
from backend.engine.blocks.base import Block, BlockContext, BlockParams
from backend.engine.blocks.input_values import InputValues
from backend.engine.embodiment import Embodiment
from backend.engine.frames import AnimationFrame
from backend.engine.library import RobotLibrary
from backend.engine.recent_events import RecentEvents
from backend.engine.runtime import Engine
from backend.errors import DomainError
from backend.graph.compiler import Compiled, Issue, ValidationReport, compile_program
from backend.graph.library_docs import library_validators
from backend.graph.schema import Program
from backend.graph.subgraph_library import standalone_issues
from backend.graph.subgraphs import inner_definition_node


class SessionError(DomainError):
    """A rejected change. `report` carries every validation error when the cause is a program.

    Codes: `invalid_program` (a program or a live change that does not compile; with the report),
    `no_program`, `unknown_node`, `unknown_param`, `invalid_param`, `block_config`, `invalid_rate`.
    """

    def __init__(self, message: str, report: ValidationReport | None = None, code: str = "invalid"):
        super().__init__(message, code=code)
        self.report = report

    @property
    def detail(self) -> dict[str, Any]:
        """The error object with the report (null when the cause is not a program's validation)."""
        return {**super().detail, "report": self.report.model_dump() if self.report else None}

    def render(self) -> str:
        if self.report is None:
            return f"nutty: error: {self}"
        lines = [f"nutty: program is invalid ({len(self.report.errors)} error(s)):"]
        for e in self.report.errors:
            where = ".".join(x for x in (e.node, e.port) if x)
            lines.append(f"  [{e.code}] {where + ': ' if where else ''}{e.message}")
        return "\n".join(lines)


def _validated_params(cls: type[Block], node_id: str, merged: dict[str, Any]) -> BlockParams:
    """`merged` validated by the block's model, or the SessionError naming the field."""
    try:
        return cls.Params.from_json_value(merged)
    except ValidationError as exc:
        err = exc.errors()[0]
        field = ".".join(str(x) for x in err["loc"])
        code = "unknown_param" if err["type"] == "extra_forbidden" else "invalid_param"
        raise SessionError(
            f"node '{node_id}' parameter '{field}': {err['msg']}",
            ValidationReport(
                valid=False, errors=[Issue(code=code, node=node_id, port=field, message=err["msg"])]
            ),
            code=code,
        ) from exc


class EngineSession:
    def __init__(self, engine: Engine, library: RobotLibrary | None = None):
        self.engine = engine
        self.embodiment: Embodiment = engine.embodiment
        self.library = library or RobotLibrary(
            _robot_folder(engine.embodiment),
            engine.embodiment,
            validators={**library_validators(), "behaviours": validate_behaviour_doc},
        )
        engine.ctx.resources = self.library
        # speech and sound events carry their start time, and a sound file's URL (backend.engine.audio_events)
        engine.set_event_stamp(functools.partial(stamp_audio, self.library.sounds))
        if self.library.sounds.folder is not None:
            self.library.sounds.warm()
        self.program: Program | None = None  # the running document (with its subgraphs, if any)
        self.flat: Program | None = None  # the running program with subgraphs flattened: the APU's node ids
        self.report: ValidationReport | None = None
        self.notes: list[dict[str, Any]] = []
        self._lock = threading.RLock()  # serialises program changes from concurrent requests
        self._note_listeners: list[Callable[[dict[str, Any]], None]] = []
        engine.add_listener(self._on_note)
        self.behaviours = BehaviourPlayer(self)  # behaviours play on the clock (backend.behaviours)
        self.recent_events = RecentEvents()  # for telemetry, which samples the frames
        engine.add_frame_observer(self.recent_events.observe, events_only=True)

    # --- construction ---------------------------------------------------------------------------
    @classmethod
    def create(
        cls,
        embodiment: Embodiment,
        *,
        rate: float | None = None,
        program_text: str | None = None,
        program: Any = None,
        max_level: int = MAX_LEVEL,
        safety: bool = True,
    ) -> EngineSession:
        """A session with a compiled program loaded (not yet ticking). Raises SessionError.

        safety=False switches the engine's safety net off (the explicit `--unsafe-no-limits`)."""
        source = program_text if program_text is not None else program
        preferred = None
        if source is not None:
            try:
                doc = json.loads(source) if isinstance(source, str) else source
                preferred = doc.get("rate") if isinstance(doc, dict) else getattr(doc, "rate", None)
            except json.JSONDecodeError:
                preferred = None
        try:
            engine = Engine(
                embodiment, rate=float(rate or preferred or 100.0), max_level=max_level, safety=safety
            )
        except ValueError as exc:
            raise SessionError(str(exc), code="invalid_rate") from exc
        session = cls(engine)
        if source is not None:
            session.load_program(source)
        return session

    def _on_note(self, note: dict[str, Any]) -> None:
        self.notes.append(note)
        if len(self.notes) > 1000:
            del self.notes[:500]
        for fn in self._note_listeners:
            fn(note)

    def on_note(self, fn: Callable[[dict[str, Any]], None]) -> None:
        """Receive block notifications (clip started/completed, errors) from the clock thread."""
        self._note_listeners.append(fn)

    # --- programs ---------------------------------------------------------------------------------
    def validate(self, source: Any) -> ValidationReport:
        return compile_program(
            source,
            self.embodiment,
            max_level=self.engine.max_level,
            ctx=self._scratch_ctx(),
            rate=self.engine.rate,
        ).report

    def validate_subgraph(self, name: str, doc: Any) -> ValidationReport:
        """Check a standalone subgraph definition (a library entry) against this robot."""
        _, issues = standalone_issues(name, doc, self.embodiment, self._scratch_ctx())
        return ValidationReport(valid=not issues, errors=issues)

    def _scratch_ctx(self):
        return BlockContext(
            embodiment=self.embodiment,
            rate=self.engine.rate,
            inputs=InputValues(self.engine.ctx.inputs),
            resources=self.library,
            compiled=self.engine.ctx.compiled,
        )

    def _compile_live(self, source: Any, refusal: str) -> Compiled:
        """Compile `source` for this engine (raises SessionError with the report if it is invalid); the
        blocks, built against a scratch context, are pointed at the engine's live one."""
        result = compile_program(
            source,
            self.embodiment,
            max_level=self.engine.max_level,
            ctx=self._scratch_ctx(),
            rate=self.engine.rate,
        )
        compiled = result.compiled()
        if compiled is None:
            raise SessionError(
                f"{refusal} ({len(result.report.errors)} error(s))", result.report, code="invalid_program"
            )
        for step in compiled.apu.steps:
            step.block.ctx = self.engine.ctx
        return compiled

    def load_program(self, source: Any) -> tuple[ValidationReport, list[str]]:
        """Validate and hot-swap a program at the next tick boundary (atomic: all or nothing).

        Returns the report and the ids of blocks that kept their state. Raises SessionError.
        """
        with self._lock:
            result = self._compile_live(source, "program is invalid")
            apu = result.apu
            declared = {i.name: i for i in result.program.inputs}

            def install_inputs() -> None:
                live = self.engine.ctx.inputs
                for name, inp in declared.items():
                    if name in live:
                        try:
                            live[name] = inp.coerce(live[name])
                            continue
                        except ValueError:
                            pass
                    live[name] = inp.coerce(inp.default)

            if self._same_structure(result.flat):
                # Parameter-only change: keep the running APU and every block, update parameters live.
                changed = self._changed_params(result.flat, result.params)

                def apply_params() -> list[str]:
                    running = self.engine.apu
                    if running is None:  # the same structure as the running program: there is one
                        raise SessionError("no program is running", code="no_program")
                    for node_id, params in changed.items():
                        running.block(node_id).update_params(params)
                    install_inputs()
                    running.source = result.program  # its editor data and subgraphs as sent
                    return [st.node_id for st in running.steps]

                kept = self.engine.call(apply_params)
                self.program = result.program
                self.flat = result.flat
                self.report = result.report
                return result.report, list(kept)

            # One tick boundary for the swap and the inputs, so no tick runs the new program without them.
            kept = self.engine.load(apu, also=install_inputs)
            self.program = result.program
            self.flat = result.flat
            self.report = result.report
            return result.report, list(kept)

    def reset(self, fade: float | None = None) -> None:
        """The running program as it starts: fresh blocks (every layer as the program declares it, no
        clip, gaze target or IK state left), inputs at their defaults, no display overrides. The robot
        moves there over `fade` seconds (at least as long as its limits need)."""
        with self._lock:
            if self.program is None:
                self.engine.load(None, adopt=False, transition=fade, also=self.engine.clear_overrides)
                return
            # The running program compiled before; only its resources (clips, postures) can have gone.
            result = self._compile_live(self.program, "the running program no longer compiles")
            defaults = {i.name: i.coerce(i.default) for i in self.program.inputs}

            def fresh_start() -> None:
                self.engine.ctx.inputs.clear()
                self.engine.ctx.inputs.update(defaults)
                self.engine.clear_overrides()

            self.engine.load(result.apu, adopt=False, transition=fade, also=fresh_start)

    def park(self, timeout: float = 3.0) -> dict[str, Any]:
        """Bring the robot to its exact rest pose within its limits and stop running the program (for
        shutdown): returns {"reached_rest", "seconds", "max_error"} (see Engine.park)."""
        with self._lock:
            return self.engine.park(timeout)

    def _same_structure(self, program: Program | None) -> bool:
        """Whether `program` differs from the running one in parameters (and editor data) only."""
        cur = self.flat
        if cur is None or program is None or self.engine.apu is None:
            return False
        # a bypass switched on or off runs another class: structural
        if [(n.id, n.type, n.bypass) for n in cur.nodes] != [(n.id, n.type, n.bypass) for n in program.nodes]:
            return False
        if sorted(e.key() for e in cur.edges) != sorted(e.key() for e in program.edges):
            return False
        if [i.model_dump() for i in cur.inputs] != [i.model_dump() for i in program.inputs]:
            return False
        if program.max_level != cur.max_level:
            return False
        for node in program.nodes:  # a parameter that changes ports (a new layer) is structural
            cls = BLOCKS[node.type]
            old = cur.node(node.id)
            if old is not None and old.params != node.params:
                try:
                    if cls.ports(cls.Params.model_validate(old.params)) != cls.ports(
                        cls.Params.model_validate(node.params)
                    ):
                        return False
                except ValidationError:
                    return False
        return True

    def _changed_params(self, program: Program, params: dict[str, Any]) -> dict[str, Any]:
        cur = self.flat
        assert cur is not None  # guarded by _same_structure; typing aid only
        return {
            n.id: params[n.id]
            for n in program.nodes
            if (old := cur.node(n.id)) is not None and old.params != n.params
        }

    def update_params(self, node_id: str, params: dict[str, Any]) -> dict[str, Any]:
        """Change one node's parameters live, without rebuilding the program (slider drags).

        `params` may be partial; they are merged over the node's current parameters, validated with
        the block's model and applied at a tick boundary. A node inside a subgraph (`idle/breathe`)
        is its definition's node: every instance of that definition changes at the same tick, and the
        program's definition keeps the new parameters. Raises SessionError naming the field.
        """
        with self._lock:
            if self.program is None or self.flat is None or self.engine.apu is None:
                raise SessionError("no program is running", code="no_program")
            node = self.flat.node(node_id)
            if node is None:
                raise SessionError(f"the running program has no node '{node_id}'", code="unknown_node")
            cls = BLOCKS[node.type]
            merged = {**node.params, **params}
            p = _validated_params(cls, node_id, merged)
            if cls.ports(p) != cls.ports(cls.Params.model_validate(node.params)):
                # Ports changed (e.g. a layer added): that is a structural edit, so swap the program.
                doc = self.program.model_copy(deep=True)
                written = inner_definition_node(doc, node_id)  # in a subgraph: its definition's node
                if written is not None:
                    written.params = p.model_dump(mode="json")
                self.load_program(doc.to_json_dict())
                return p.model_dump(mode="json")
            try:
                cls(p, self._scratch_ctx(), node_id)  # dry run: configure() errors surface here
            except ValueError as exc:
                raise SessionError(
                    f"node '{node_id}': {exc}",
                    ValidationReport(
                        valid=False, errors=[Issue(code="block_config", node=node_id, message=str(exc))]
                    ),
                    code="block_config",
                ) from exc
            apu, flat, program = self.engine.apu, self.flat, self.program
            written = inner_definition_node(program, node_id)  # in a subgraph: its definition's node
            ids = [node_id]  # the flat ids that run it: inside a subgraph, every instance of the definition
            if "/" in node_id and written is not None:
                ids = [
                    n.id
                    for n in flat.nodes
                    if "/" in n.id and inner_definition_node(program, n.id) is written
                ]
            blocks = [(apu.block(i), p.model_copy(deep=True)) for i in ids]
            self.engine.call(lambda: [block.update_params(own) for block, own in blocks])
            for i in ids:
                if (running := flat.node(i)) is not None:
                    running.params = dict(merged)
            if written is not None:
                written.params = dict(merged)  # as the author wrote them: defaults stay implicit
            return merged

    # --- inputs -------------------------------------------------------------------------------------
    def set_input(self, name: str, value: Any) -> Any:
        """Set an exposed input (checked against its declaration). Raises ValueError naming it."""
        decl = self.program.input(name) if self.program is not None else None
        if decl is None:
            declared = [i.name for i in self.program.inputs] if self.program else []
            raise ValueError(f"the running program has no exposed input '{name}' (declared: {declared})")
        value = decl.coerce(value)
        self.engine.call(lambda: self.engine.ctx.inputs.__setitem__(name, value))
        return value

    def inputs(self) -> dict[str, Any]:
        return dict(self.engine.ctx.inputs)

    # --- headless running -----------------------------------------------------------------------------
    def read_command_file(self, path: str | Path) -> list[tuple[float, dict[str, Any]]]:
        """Timed commands, one JSON object per line: {"t": seconds, ...command...}. Sorted by t."""
        timeline = []
        for lineno, line in enumerate(Path(path).read_text().splitlines(), 1):
            if not line.strip() or line.lstrip().startswith("#"):
                continue
            try:
                item = json.loads(line)
            except json.JSONDecodeError as exc:
                raise ValueError(f"{path}:{lineno}: malformed JSON: {exc.msg}") from exc
            if not isinstance(item, dict) or not isinstance(item.get("t"), (int, float)):
                raise ValueError(f"{path}:{lineno}: each line needs a numeric 't' (seconds)")
            t = float(item.pop("t"))
            self.check_command(item, where=f"{path}:{lineno}")
            timeline.append((t, item))
        timeline.sort(key=lambda x: x[0])
        return timeline

    def check_command(self, command: dict[str, Any], where: str = "command") -> None:
        """Validate a command before it is scheduled (raises ValueError naming the field)."""
        control.parse_command(command, where=where)

    def execute(self, command: dict[str, Any]) -> Any:
        """Carry out one command now (at the next tick boundary)."""
        return control.execute(self, control.parse_command(command))

    def run_headless(
        self, n_ticks: int, timeline: list[tuple[float, dict[str, Any]]] | None = None
    ) -> Iterator[AnimationFrame]:
        """Tick `n_ticks` times without sleeping, applying timed commands when their time comes."""
        pending = list(timeline or [])
        k = 0
        for _ in range(n_ticks):
            while k < len(pending) and pending[k][0] <= self.engine.t + 1e-9:
                self.execute(dict(pending[k][1]))
                k += 1
            yield self.engine.tick()


def _robot_folder(emb: Embodiment) -> Path | None:
    if emb.urdf_path is None:
        return None
    folder = emb.urdf_path.parent
    return folder if (folder / "embodiment.yaml").exists() else None

"""Programs and their parts: the block catalog, dynamic ports, the JSON Schemas, and the running
program (read, validate, hot-swap, live parameter changes)."""

from __future__ import annotations

import asyncio
from typing import Any

from fastapi import APIRouter
from pydantic import ValidationError

from backend import control
from backend.engine.blocks import BLOCKS, block_catalog
from backend.graph.schema import program_json_schema
from backend.routes.bodies import ParamValues, PortsRequest, ProgramDoc
from backend.routes.errors import api_error
from backend.routes.json_body import SafeJsonRoute
from backend.routes.state import HubDep, SessionDep
from backend.routes.tools import tools_changed
from backend.session import SessionError

router = APIRouter(prefix="/api", route_class=SafeJsonRoute, tags=["program"])


def _report(exc: SessionError) -> dict[str, Any] | None:
    return exc.report.model_dump() if exc.report else None


@router.get("/blocks", summary="Every block type with its parameter JSON Schema, ports, category and doc")
def blocks() -> list[dict[str, Any]]:
    return block_catalog()


@router.post("/blocks/{type_name}/ports", summary="Ports of a block for given parameters (dynamic ports)")
def block_ports(type_name: str, body: PortsRequest) -> dict[str, Any]:
    cls = BLOCKS.get(type_name)
    if cls is None:
        raise api_error(404, "unknown_block_type", f"unknown block type '{type_name}'")
    try:
        ins, outs = cls.ports(cls.Params.model_validate(body.params))
    except (ValidationError, ValueError, TypeError) as exc:
        raise api_error(422, "invalid_param", str(exc)) from exc
    return {
        "inputs": {k: v.to_dict() for k, v in ins.items()},
        "outputs": {k: v.to_dict() for k, v in outs.items()},
    }


@router.get("/schema/program", summary="JSON Schema of the program document")
def schema_program() -> dict[str, Any]:
    return program_json_schema()


@router.get("/schema/commands", summary="JSON Schema of the command union")
def schema_commands() -> dict[str, Any]:
    return control.command_json_schema()


@router.get("/program", summary="The running program, its validation report and APU level")
def get_program(session: SessionDep) -> dict[str, Any]:
    from backend.graph.roundtrip import apu_to_program

    apu = session.engine.apu
    prog = apu_to_program(apu).to_json_dict() if apu is not None and session.program is not None else None
    return {
        "program": prog,
        "report": session.report.model_dump() if session.report else None,
        "level": apu.level if apu else None,
    }


@router.post("/program/validate", summary="Validate a program (200 with the report, valid or not)")
async def validate_program(doc: ProgramDoc, session: SessionDep) -> dict[str, Any]:
    return (await asyncio.to_thread(session.validate, doc)).model_dump()


@router.put("/program", summary="Validate and hot-swap a program (atomic)")
async def put_program(doc: ProgramDoc, session: SessionDep, hub: HubDep) -> dict[str, Any]:
    try:
        report, kept = await asyncio.to_thread(session.load_program, doc)
    except SessionError as exc:
        raise api_error(422, "invalid_program", str(exc), report=_report(exc)) from exc
    await tools_changed(hub)  # the program decides which tools exist (its blocks, inputs, layers)
    return {"report": report.model_dump(), "kept": kept}


@router.patch(
    "/program/nodes/{node_id:path}/params",
    summary="Change one node's parameters live, without rebuilding the program",
)
async def patch_params(node_id: str, params: ParamValues, session: SessionDep, hub: HubDep) -> dict[str, Any]:
    if not isinstance(params, dict):
        raise api_error(422, "invalid_param", "the body is an object of parameter name -> value")
    try:
        changed = await asyncio.to_thread(session.update_params, node_id, params)
    except SessionError as exc:
        status = 404 if exc.code in ("unknown_node", "no_program") else 422
        raise api_error(status, exc.code, str(exc), report=_report(exc)) from exc
    await tools_changed(hub)  # a parameter can add a layer
    return {"params": changed}

"""Programs and their parts: the block catalog, dynamic ports, the JSON Schemas, and the running
program (read, validate, hot-swap, live parameter changes)."""

from __future__ import annotations

import asyncio
from typing import Any

from fastapi import APIRouter
from pydantic import ValidationError

from backend import control
from backend.api_types import (
    BlockEntry,
    BlockPorts,
    JsonSchemaDocument,
    ParamsApplied,
    ProgramLoaded,
    RunningProgram,
    ValidationReport,
)
from backend.engine.blocks import BLOCKS, block_catalog
from backend.errors import DomainError
from backend.graph.roundtrip import apu_to_program
from backend.graph.schema import program_json_schema
from backend.routes.bodies import ParamValues, PortsRequest, ProgramDoc
from backend.routes.json_body import SafeJsonRoute
from backend.routes.state import HubDep, SessionDep
from backend.routes.tools import tools_changed

router = APIRouter(prefix="/api", route_class=SafeJsonRoute, tags=["program"])


@router.get(
    "/blocks",
    response_model=list[BlockEntry],
    summary="Every block type with its parameter JSON Schema, ports, category and doc",
)
def blocks() -> list[dict[str, Any]]:
    return block_catalog()


@router.post(
    "/blocks/{type_name}/ports",
    response_model=BlockPorts,
    summary="Ports of a block for given parameters (dynamic ports)",
)
def block_ports(type_name: str, body: PortsRequest) -> dict[str, Any]:
    cls = BLOCKS.get(type_name)
    if cls is None:
        raise DomainError(f"unknown block type '{type_name}'", code="unknown_block_type")
    try:
        ins, outs = cls.ports(cls.Params.model_validate(body.params))
    except (ValidationError, ValueError, TypeError) as exc:
        raise DomainError(str(exc), code="invalid_param") from exc
    return {
        "inputs": {k: v.to_dict() for k, v in ins.items()},
        "outputs": {k: v.to_dict() for k, v in outs.items()},
    }


@router.get(
    "/schema/program", response_model=JsonSchemaDocument, summary="JSON Schema of the program document"
)
def schema_program() -> dict[str, Any]:
    return program_json_schema()


@router.get("/schema/commands", response_model=JsonSchemaDocument, summary="JSON Schema of the command union")
def schema_commands() -> dict[str, Any]:
    return control.command_json_schema()


@router.get(
    "/program",
    response_model=RunningProgram,
    summary="The running program, its validation report and APU level",
)
def get_program(session: SessionDep) -> dict[str, Any]:
    apu = session.engine.apu
    prog = apu_to_program(apu).to_json_dict() if apu is not None and session.program is not None else None
    return {
        "program": prog,
        "report": session.report.model_dump() if session.report else None,
        "level": apu.level if apu else None,
    }


@router.post(
    "/program/validate",
    response_model=ValidationReport,
    summary="Validate a program (200 with the report, valid or not)",
)
async def validate_program(doc: ProgramDoc, session: SessionDep) -> dict[str, Any]:
    return (await asyncio.to_thread(session.validate, doc)).model_dump()


@router.put("/program", response_model=ProgramLoaded, summary="Validate and hot-swap a program (atomic)")
async def put_program(doc: ProgramDoc, session: SessionDep, hub: HubDep) -> dict[str, Any]:
    # A program that does not compile: the session's SessionError `invalid_program`, with the report.
    report, kept = await asyncio.to_thread(session.load_program, doc)
    await tools_changed(hub)  # the program decides which tools exist (its blocks, inputs, layers)
    return {"report": report.model_dump(), "kept": kept}


@router.patch(
    "/program/nodes/{node_id:path}/params",
    response_model=ParamsApplied,
    summary="Change one node's parameters live, without rebuilding the program",
)
async def patch_params(node_id: str, params: ParamValues, session: SessionDep, hub: HubDep) -> dict[str, Any]:
    if not isinstance(params, dict):
        raise DomainError("the body is an object of parameter name -> value", code="invalid_param")
    # Refused: the session's SessionError (`unknown_node`, `invalid_param`, ... with the report).
    changed = await asyncio.to_thread(session.update_params, node_id, params)
    await tools_changed(hub)  # a parameter can add a layer
    return {"params": changed}

"""The robot: its embodiment (kinematronics table, with each joint's frame and axis), its URDF and its
visual meshes as GLB (for DCC tools such as the Blender add-on)."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter
from fastapi.responses import PlainTextResponse, Response

from backend.api_types import RobotDescription
from backend.engine.visual_scene import NoVisuals, scene_glb
from backend.errors import DomainError
from backend.routes.json_body import SafeJsonRoute
from backend.routes.state import SessionDep

router = APIRouter(prefix="/api", route_class=SafeJsonRoute, tags=["robot"])


@router.get(
    "/robot", response_model=RobotDescription, summary="The robot's embodiment and kinematronics table"
)
def robot(session: SessionDep) -> dict[str, Any]:
    return {**session.embodiment.to_dict(), "urdf": "/api/robot/urdf"}


@router.get("/robot/urdf", response_class=PlainTextResponse, summary="The robot's URDF")
def robot_urdf(session: SessionDep) -> str:
    if session.embodiment.urdf_path is None:
        raise DomainError("this robot has no URDF file", code="no_urdf")
    return session.embodiment.urdf_path.read_text()


@router.get(
    "/robot/scene.glb",
    response_class=Response,
    summary="The robot's visual meshes (GLB, every joint at zero)",
    responses={200: {"content": {"model/gltf-binary": {"schema": {"type": "string", "format": "binary"}}}}},
)
def robot_scene(session: SessionDep) -> Response:
    try:
        glb = scene_glb(session.embodiment)
    except NoVisuals as exc:
        raise DomainError(str(exc), code="no_visuals") from exc
    return Response(glb, media_type="model/gltf-binary")

"""Nutty for Blender: rig the running robot, animate it, see where it breaks the robot's limits and the
motion filter's ghost, export clips to the engine, and puppeteer the live robot (docs/blender.md).

Talks to a running `nutty serve` over HTTP and WebSocket with the standard library; uses nothing from
the Nutty backend. Modules: client (HTTP, WebSocket), robot (the rig plan, plain Python), rig (the
armature), display (the display DoFs' drivers), load, clip (export and sampling), bake (the evaluated
pose as smooth keys), clip_import and curve_math (Import clip), preview (what Check limits and Ghost
post), limits, ghost, live (the live link), settings, operators, ui (the Nutty menu and panel).
"""

import bpy

from . import live, operators, settings, ui


@bpy.app.handlers.persistent
def _stop_link_on_load(*_args) -> None:
    """A new file ends the live link (its handlers and timer do not survive the load)."""
    if live.LINK.running:
        live.LINK.stop()


def register() -> None:
    settings.register()
    for cls in operators.CLASSES:
        bpy.utils.register_class(cls)
    ui.register()
    bpy.app.handlers.load_pre.append(_stop_link_on_load)


def unregister() -> None:
    if live.LINK.running:
        live.LINK.stop()
    if _stop_link_on_load in bpy.app.handlers.load_pre:
        bpy.app.handlers.load_pre.remove(_stop_link_on_load)
    ui.unregister()
    for cls in reversed(operators.CLASSES):
        bpy.utils.unregister_class(cls)
    settings.unregister()

"""The display DoFs in the viewport: drivers from the rig's properties onto the meshes of the links
each display DoF names (`links` in GET /api/robot), so scrubbing shows what the robot's lights and
face show.

- A colour DoF (e.g. `eye_leds`, r, g, b in 0..1) colours its links' meshes: the object colour (what
  the Workbench's Object colour shows) and a material of their own (Base Color and Emission of the
  Principled BSDF, and the viewport's diffuse colour), each channel clamped to 0..1 as the engine does.
- An enum DoF (e.g. `mouth`, the option's index) tints its meshes' object colour, one hue per option.
- A continuous display DoF (e.g. `mouth_open`, 0..1) stretches its meshes along their local Z (1x at
  its minimum, 3x at its maximum).

Drivers use Blender's simple expressions (no Python auto-run needed).
"""

from __future__ import annotations

from typing import Any

from .rig import link_of

LED_MATERIAL_SUFFIX = " (Nutty LED)"
STRETCH = 2.0  # extra length along Z of a continuous display DoF's mesh at its maximum


def _var(drv: Any, rig_ob: Any, path: str, name: str = "v") -> None:
    var = drv.variables.new()
    var.name, var.type = name, "SINGLE_PROP"
    var.targets[0].id_type = "OBJECT"
    var.targets[0].id = rig_ob
    var.targets[0].data_path = path


def _drive(owner: Any, prop: str, index: int, rig_ob: Any, path: str, expression: str) -> None:
    drv = owner.driver_add(prop, index).driver
    drv.type = "SCRIPTED"
    _var(drv, rig_ob, path)
    drv.expression = expression


def _led_material(mesh_ob: Any, dof: str, rig_ob: Any) -> None:
    """A material of the mesh's own (copied from its first), its colours driven by the DoF."""
    if not mesh_ob.material_slots or mesh_ob.material_slots[0].material is None:
        return
    base = mesh_ob.material_slots[0].material
    mat = base.copy()
    mat.name = f"{mesh_ob.name}{LED_MATERIAL_SUFFIX}"
    mesh_ob.material_slots[0].link = "OBJECT"  # the mesh data (maybe shared) keeps its material
    mesh_ob.material_slots[0].material = mat
    for c in range(3):
        path, expression = f'["{dof}"][{c}]', "min(max(v, 0.0), 1.0)"
        _drive(mat, "diffuse_color", c, rig_ob, path, expression)
        bsdf = mat.node_tree.nodes.get("Principled BSDF") if mat.use_nodes and mat.node_tree else None
        if bsdf is None:
            continue
        for socket in ("Base Color", "Emission Color"):
            if socket in bsdf.inputs:
                _drive(bsdf.inputs[socket], "default_value", c, rig_ob, path, expression)


def drive_display(rig_ob: Any, robot: dict[str, Any], meshes: list[Any]) -> int:
    """Drivers for every display DoF of `robot` onto its links' meshes among `meshes`; how many meshes
    got one."""
    by_link: dict[str, list[Any]] = {}
    for m in meshes:
        by_link.setdefault(link_of(m), []).append(m)
    driven = set()
    for d in robot.get("dofs") or []:
        if d.get("dimension") != "display" or d["name"] not in rig_ob:
            continue
        targets = [m for link in d.get("links") or [] for m in by_link.get(link, [])]
        name = d["name"]
        for m in targets:
            if d["type"] == "colour":
                for c in range(3):
                    _drive(m, "color", c, rig_ob, f'["{name}"][{c}]', "min(max(v, 0.0), 1.0)")
                _led_material(m, name, rig_ob)
            elif d["type"] == "enum":  # one hue per option: 0.5 + 0.5 sin(2.4 i + phase)
                for c, phase in enumerate((0.0, 2.1, 4.2)):
                    _drive(m, "color", c, rig_ob, f'["{name}"]', f"0.5 + 0.5*sin(2.4*v + {phase})")
            elif d["type"] == "continuous":
                lo, hi = float(d.get("min") or 0.0), float(d.get("max") or 1.0)
                span = hi - lo if hi > lo else 1.0
                expression = f"1.0 + {STRETCH}*min(max((v - {lo!r})/{span!r}, 0.0), 1.0)"
                _drive(m, "scale", 2, rig_ob, f'["{name}"]', expression)
            else:
                continue
            driven.add(m.name)
    return len(driven)


def clear_drivers(mesh_ob: Any) -> None:
    """Remove the display drivers of a mesh (the ghost's copies show the ghost's own colour)."""
    if mesh_ob.animation_data is not None:
        mesh_ob.animation_data_clear()

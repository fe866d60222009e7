"""From the robot's description (GET /api/robot) to a rig plan: which bones, custom properties and
drivers the armature gets, in plain Python (no bpy), so it can be read and checked on its own.

Bones: one per moving URDF joint, named after the joint, its head at the joint's origin and its +Y
axis along the joint axis, so the joint angle is the bone's local Y rotation (Euler YXZ: Y first,
so the whole range of a joint is one channel). A joint driven 1:1 by a stationary DoF is that DoF's
*control* bone (the animator rotates it; Limit Rotation holds it within the DoF's limits). Symbolic
DoFs (e.g. gaze_yaw -> body_yaw 0.3, head_yaw 0.7) are custom properties; every joint they drive gets a
hidden *drive* bone under its control bone (or alone, for a joint no DoF drives 1:1) whose Y rotation
is a driver computing what the engine computes (backend/engine/embodiment.py, `joint_positions`):

    joint = clamp(clamp(dof, dof_limits) + sum(coef * (clamp(symbolic, its limits) - symbolic_rest)),
                  joint_lower, joint_upper)

(a joint without its own DoF: `clamp(rest + sum(...))`). Every value is clamped inside the expression
(clamping is idempotent), so the drive bone is right whatever Blender's evaluation order: whether the
control bone's angle the driver reads is taken before or after its Limit Rotation, and however far an
F-curve overshoots a property's limits (Blender enforces a property's min/max only in its UI). The
drive bone (else the control bone) is the joint's *link bone*: the meshes of the links the joint moves,
and the joints below it, hang from it.

Units: rad and m; positions in the robot's base frame (+X forward, +Z up) with every joint at zero.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

SUPPORTED_JOINTS = ("revolute", "continuous")
DRIVE_SUFFIX = ".drive"


class RigError(Exception):
    """The robot cannot be rigged as described; the message says which joint or DoF and why."""


@dataclass
class BonePlan:
    name: str
    joint: str
    head: tuple[float, float, float]
    axis: tuple[float, float, float]  # unit, base frame: the bone's +Y
    roll_ref: tuple[float, float, float]  # a direction the bone's +Z should face (the joint frame's X or Z)
    parent: str | None  # parent bone (a link bone), None: the armature itself
    dof: str | None = None  # the DoF this bone's Y rotation is (control bones)
    limits: tuple[float, float] | None = None  # Limit Rotation on Y (rad), control bones
    rest: float = 0.0  # the DoF's rest value (rad): the bone's initial pose
    expression: str | None = None  # driver expression of the Y rotation (drive bones)
    variables: dict[str, tuple[str, str]] = field(
        default_factory=dict
    )  # var -> ("prop", name) | ("bone", name)
    hidden: bool = False


@dataclass
class PropPlan:
    """A custom property of the armature object: a symbolic, display or audible DoF."""

    name: str
    kind: str  # "float" (symbolic or continuous display), "colour", "enum", "sound"
    default: Any
    min: float | None = None
    max: float | None = None
    options: list[str] = field(default_factory=list)  # enum: option names; sound: "-" then the sounds
    description: str = ""


@dataclass
class RigPlan:
    robot: str
    bones: list[BonePlan]
    props: list[PropPlan]
    link_bones: dict[str, str | None]  # link -> the bone its meshes hang from (None: the armature)
    joint_bones: dict[str, str]  # joint -> its link bone (what the joint angle is read from)
    dof_bones: dict[str, str]  # DoF -> its control bone
    speech: str | None  # the speech DoF (for `say:` markers)
    sound: str | None  # the sound DoF (for `sound:` markers and the sound property)
    warnings: list[str] = field(default_factory=list)


def _fmt(x: float) -> str:
    return repr(float(x))


@dataclass(frozen=True)
class Drive:
    """One symbolic DoF's term in a joint: coefficient x (value clamped to [lower, upper] - rest)."""

    dof: str
    coef: float
    rest: float
    lower: float | None  # the symbolic DoF's limits (its unit), None: unbounded
    upper: float | None


def _sum_terms(drives: list[Drive]) -> tuple[str, dict[str, tuple[str, str]]]:
    """`c1*(clamp(s1) - r1) + ...` over the symbolic DoFs driving a joint, with its driver variables."""
    terms, variables = [], {}
    for k, d in enumerate(drives):
        var = f"s{k}"
        variables[var] = ("prop", d.dof)
        value = _clamp(var, d.lower, d.upper)  # the engine clamps a DoF to its limits before composing
        terms.append(
            f"{_fmt(d.coef)}*{value}" if d.rest == 0.0 else f"{_fmt(d.coef)}*({value} - {_fmt(d.rest)})"
        )
    return " + ".join(terms), variables


def _clamp(expr: str, lower: float | None, upper: float | None) -> str:
    if lower is not None:
        expr = f"max({expr}, {_fmt(lower)})"
    if upper is not None:
        expr = f"min({expr}, {_fmt(upper)})"
    return expr


def _refuse_unsupported(robot: dict[str, Any], frames: dict[str, Any], needed: set[str]) -> None:
    """RigError naming every joint a DoF needs that is missing or not a plain rotation."""

    def kind(j: str) -> str | None:
        if j not in frames:
            return "missing"
        f = frames[j]
        return "mimic" if f.get("mimic") else None if f["type"] in SUPPORTED_JOINTS else f["type"]

    bad = [f"'{j}' ({kind(j)})" for j in sorted(needed) if kind(j) is not None]
    if bad:
        raise RigError(
            f"robot '{robot.get('name')}' has joints the add-on cannot rig: {', '.join(bad)}. It rigs "
            f"revolute and continuous joints (one rotation channel per bone)"
        )


def _within_half_turn(lower: float | None, upper: float | None) -> bool:
    """Both limits given and within +-pi (rad): a range Limit Rotation holds without wrapping."""
    return lower is not None and upper is not None and -math.pi <= float(lower) <= float(upper) <= math.pi


def _joint_bones(
    name: str,
    f: dict[str, Any],
    parent: str | None,
    dof: dict[str, Any] | None,
    drives: list[Drive] | None,
) -> list[BonePlan]:
    """The bones of one joint, its link bone last: the DoF's control bone, a drive bone for the symbolic
    DoFs that drive it (under the control bone, or alone), or a locked bone for a joint nothing drives."""
    rot = f["rotation"]
    axis = tuple(float(a) for a in f["axis"])
    x_axis = (rot[0][0], rot[1][0], rot[2][0])  # the joint frame's X, unless it is the axis itself
    z_axis = (rot[0][2], rot[1][2], rot[2][2])
    roll_ref = x_axis if abs(sum(a * b for a, b in zip(x_axis, axis))) < 0.9 else z_axis
    common = dict(joint=name, head=tuple(f["origin"]), axis=axis, roll_ref=roll_ref)
    lower, upper = f["limits"]
    bones = []
    if dof is not None:
        limits = None
        if f["type"] == "revolute":  # the DoF's limits, within the joint's (the engine clamps to both)
            limits = (
                max(float(dof["min"]), lower if lower is not None else float(dof["min"])),
                min(float(dof["max"]), upper if upper is not None else float(dof["max"])),
            )
        elif _within_half_turn(dof.get("min"), dof.get("max")):  # continuous: the DoF's own limits
            limits = (float(dof["min"]), float(dof["max"]))
        bones.append(
            BonePlan(
                name=name,
                parent=parent,
                dof=dof["name"],
                rest=float(dof.get("rest") or 0.0),
                limits=limits,
                **common,
            )
        )
    if drives:
        sums, variables = _sum_terms(drives)
        if dof is not None:  # the joint = its DoF (the control bone's angle) + the symbolic terms
            variables["d"] = ("bone", name)
            # `d` clamped to the control bone's Limit Rotation: what the parent shows, whether the driver
            # reads the angle before or after that constraint
            own = "d" if bones[0].limits is None else _clamp("d", *bones[0].limits)
            expression = f"{_clamp(f'{own} + {sums}', lower, upper)} - {own}"
            bones.append(
                BonePlan(
                    name=name + DRIVE_SUFFIX,
                    parent=name,
                    expression=expression,
                    variables=variables,
                    hidden=True,
                    **common,
                )
            )
        else:  # no DoF of its own: the joint rests where the engine rests it, plus the symbolic terms
            rest = 0.0 if lower is None else max(0.0, lower)  # the engine's rest of an undriven joint
            rest = rest if upper is None else min(rest, upper)
            expression = _clamp(f"{_fmt(rest)} + {sums}", lower, upper)
            bones.append(
                BonePlan(name=name, parent=parent, expression=expression, variables=variables, **common)
            )
    if not bones:  # a joint nothing drives: a locked bone (the engine holds it at zero)
        bones.append(BonePlan(name=name, parent=parent, **common))
    return bones


def plan_rig(robot: dict[str, Any]) -> RigPlan:
    """The rig of `robot` (the JSON of GET /api/robot). RigError when a DoF needs a joint the add-on
    cannot rig (prismatic, planar, floating or mimic joints, or a robot without joint frames)."""
    frames: dict[str, dict[str, Any]] = robot.get("joint_frames") or {}
    dofs: list[dict[str, Any]] = robot.get("dofs") or []
    if not frames:
        raise RigError(
            f"robot '{robot.get('name')}' has no joint frames: the server is older than the add-on, "
            f"or the robot has no URDF"
        )
    stationary = [d for d in dofs if d.get("dimension") == "stationary" and d.get("type") == "continuous"]
    real = {d["joint"]: d for d in stationary if d.get("joint") and not d.get("drives")}
    symbolic = [d for d in stationary if d.get("drives")]
    _refuse_unsupported(robot, frames, set(real) | {j for d in symbolic for j in d["drives"]})
    drives_of: dict[str, list[Drive]] = {}
    for d in symbolic:
        lo, hi = d.get("min"), d.get("max")
        for joint, coef in d["drives"].items():
            drives_of.setdefault(joint, []).append(
                Drive(
                    d["name"],
                    float(coef),
                    float(d.get("rest") or 0.0),
                    None if lo is None else float(lo),
                    None if hi is None else float(hi),
                )
            )
    link_bone: dict[str, str | None] = {}  # joint -> the bone its links and child joints hang from
    bones: list[BonePlan] = []
    warnings: list[str] = []
    for name, f in frames.items():  # parents first
        parent = link_bone.get(f["parent_joint"]) if f["parent_joint"] else None
        if f["type"] not in SUPPORTED_JOINTS or f.get("mimic"):  # no DoF needs it (else refused above)
            warnings.append(
                f"joint '{name}' ({f['type']}{', mimic' if f.get('mimic') else ''}) is not rigged: "
                f"its links move with '{f['parent_joint'] or 'the base'}'"
            )
            link_bone[name] = parent
            continue
        planned = _joint_bones(name, f, parent, real.get(name), drives_of.get(name))
        bones += planned
        link_bone[name] = planned[-1].name
    links: dict[str, str | None] = {link: None for link in robot.get("root_links") or []}
    for name, f in frames.items():
        for link in f["links"]:
            links[link] = link_bone.get(name)
    spatial = [d["name"] for d in dofs if d.get("dimension") == "spatial"]
    if spatial:
        warnings.append(f"spatial DoFs ({', '.join(spatial)}) are not rigged: animate the base in the editor")
    audible = {d.get("kind"): d["name"] for d in dofs if d.get("dimension") == "audible"}
    return RigPlan(
        robot=str(robot.get("name")),
        bones=bones,
        props=_props(robot, symbolic),
        link_bones=links,
        joint_bones={j: b for j, b in link_bone.items() if b is not None},
        dof_bones={b.dof: b.name for b in bones if b.dof},
        speech=audible.get("speech"),
        sound=audible.get("sound"),
        warnings=warnings,
    )


def _props(robot: dict[str, Any], symbolic: list[dict[str, Any]]) -> list[PropPlan]:
    props = [
        PropPlan(
            d["name"],
            "float",
            float(d.get("rest") or 0.0),
            d.get("min"),
            d.get("max"),
            description=f"symbolic DoF: drives {d['drives']} (rad)",
        )
        for d in symbolic
    ]
    for d in robot.get("dofs") or []:
        desc = d.get("description") or ""
        if d.get("dimension") == "display":
            if d["type"] == "colour":
                props.append(
                    PropPlan(
                        d["name"],
                        "colour",
                        list(d.get("rest") or [0, 0, 0]),
                        0.0,
                        1.0,
                        description=desc or "LED colour",
                    )
                )
            elif d["type"] == "enum":
                options = list(d.get("options") or [])
                rest = d.get("rest") or 0
                props.append(
                    PropPlan(
                        d["name"],
                        "enum",
                        round(float(rest)),
                        0,
                        max(0, len(options) - 1),
                        options,
                        description=f"{desc} (0..{len(options) - 1}: {', '.join(options)})",
                    )
                )
            elif d["type"] == "continuous":
                props.append(
                    PropPlan(
                        d["name"],
                        "float",
                        float(d.get("rest") or 0.0),
                        d.get("min"),
                        d.get("max"),
                        description=desc,
                    )
                )
        elif d.get("dimension") == "audible" and d.get("kind") == "sound":
            sounds = list(d.get("sounds") or [])
            props.append(
                PropPlan(
                    d["name"],
                    "sound",
                    0,
                    0,
                    len(sounds),
                    ["-", *sounds],
                    description=f"key a sound: 1..{len(sounds)} = {', '.join(sounds)} (0: none)",
                )
            )
    return props

"""A robot's URDF compiled into MuJoCo for the physics preview (`nutty serve --sim mujoco`).

One MuJoCo body per URDF link (a fixed joint makes a child body with no joint of its own, so MuJoCo
welds it to its parent), one hinge or slide joint per moving URDF joint with the URDF's range as a hard
stop, one position actuator per actuated joint, gravity along -Z, and a floor plane under the robot's
lowest point at rest. Mimic joints follow their leader through a joint equality. Links in contact are
reported unless they are parent and child, or joined through links without shapes (a gimbal).

What the URDF does not say is assumed, and `SimModel.notes` says so (the log repeats it):

- **Collision shapes:** a link's `<collision>` elements, or its `<visual>` ones when it has none.
- **Mass and inertia:** a link's `<inertial>`, or its shapes' volume at `DENSITY` (a printed shell
  with parts inside); a link with neither gets `EMPTY_MASS`.
- **Meshes:** STL and OBJ are read by MuJoCo itself; other formats (DAE, GLB, PLY, ...) through trimesh.
  MuJoCo collides with a mesh's convex hull.
- **Actuators** (per joint, from `hardware.yaml` when given: `kp`, `kd`, `effort`, `armature`): the
  effort limit is the URDF's `<limit effort>`; `kp` makes the motor reach that effort `SATURATION_ERROR`
  away from its goal; `kd` damps critically (MuJoCo's `dampratio` 1) for the joint's inertia at rest;
  the rotor's reflected inertia is `ARMATURE`.

Units: SI (m, rad, kg, N·m or N for a slide joint, s).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from backend.engine.embodiment import Embodiment
    from backend.hardware.config import Hardware


from backend.sim.availability import mujoco_module

#: The [sim] extra (require_mujoco says how to install it when it is missing).
mujoco = mujoco_module()
log = logging.getLogger(__name__)

#: Density of a link whose URDF has no <inertial> (kg/m³): a 3D-printed shell with parts inside.
DENSITY = 300.0
#: The mass of a link with neither <inertial> nor shapes (kg), so that MuJoCo can move it.
EMPTY_MASS = 0.001
#: Default position gain: the motor reaches its effort limit this far from its goal (rad or m).
SATURATION_ERROR = 0.05
#: Default reflected rotor inertia of a joint's motor (kg·m², or kg for a slide): a small geared servo.
ARMATURE = 2e-4
#: Effort limit of a joint whose URDF gives none (N·m or N).
DEFAULT_EFFORT = 1.0
#: Physics step (s): 1 kHz.
TIMESTEP = 0.001

_MUJOCO_MESHES = {".stl", ".obj", ".msh"}


@dataclass(frozen=True)
class Gains:
    """One joint's actuator: `effort` the force limit (N·m or N), `kp` (N·m/rad), `kd` (N·m·s/rad; None:
    critically damped), `armature` (kg·m²)."""

    effort: float
    kp: float
    kd: float | None = None
    armature: float = ARMATURE


@dataclass
class SimModel:
    """A compiled model and where the robot's joints sit in it.

    `joints` are the embodiment's joints (emb.joint_names order); joint k is MuJoCo actuator k, with its
    position at `qpos[qpos_adr[k]]` and velocity at `qvel[dof_adr[k]]`. `body_links[b]` is the URDF link
    of MuJoCo body b ("world" for body 0). `base_mocap` is the mocap index of the root link (it follows
    the frame's spatial DoFs), or -1 when the robot has none.
    """

    model: Any
    joints: list[str]
    qpos_adr: np.ndarray
    dof_adr: np.ndarray
    effort: np.ndarray
    gains: dict[str, Gains]
    body_links: list[str]
    parent_link: dict[str, str | None]
    base_mocap: int
    floor_z: float
    table_z: float | None
    notes: list[str] = field(default_factory=list)


def gains_for(emb: Embodiment, hardware: Hardware | None = None) -> dict[str, Gains]:
    """Each actuated joint's actuator: `hardware.yaml`'s kp/kd/effort where given, else from the URDF."""
    urdf = _urdf(emb)
    servo: dict[str, Any] = {}
    if hardware is not None:
        for bus in hardware.buses:
            servo.update(getattr(bus, "joints", {}))
    out: dict[str, Gains] = {}
    for name in emb.joint_names:
        limit = urdf.joint_map[name].limit
        urdf_effort = float(limit.effort) if limit is not None and limit.effort else DEFAULT_EFFORT
        cfg = servo.get(name)
        effort = float(getattr(cfg, "effort", None) or urdf_effort)
        kp = getattr(cfg, "kp", None) or effort / SATURATION_ERROR
        armature = getattr(cfg, "armature", None)
        out[name] = Gains(
            effort=effort,
            kp=float(kp),
            kd=getattr(cfg, "kd", None),
            armature=float(ARMATURE if armature is None else armature),
        )
    return out


def build(
    emb: Embodiment,
    gains: dict[str, Gains] | None = None,
    table: float | None = None,
    timestep: float = TIMESTEP,
) -> SimModel:
    """Compile `emb`'s URDF into MuJoCo (SimError saying why not). `table`: the height (m) above the
    floor of a horizontal table plane whose underside counts as inside, or None."""
    gains = gains or gains_for(emb)
    urdf = _urdf(emb)
    spec = mujoco.MjSpec()
    spec.modelname = emb.name
    spec.option.timestep = timestep
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_AUTO
    spec.compiler.degree = False  # URDF angles are radians (MuJoCo's compiler assumes degrees)
    notes: list[str] = []
    folder = emb.urdf_path.parent if emb.urdf_path is not None else Path(".")  # (_urdf needs a path)
    builder = _Builder(spec, urdf, folder, gains, notes)
    root = builder.root()
    spatial = any(d.dimension.value == "spatial" for d in emb.dofs)
    body = spec.worldbody.add_body(name=root, mocap=spatial)
    builder.add_link(body, root)
    if spatial:  # a mocap body is not welded to the world: keep the base's own contact with it out
        spec.add_exclude(bodyname1="world", bodyname2=root)
    builder.exclude_gimbals()
    for name in emb.joint_names:
        builder.add_actuator(name)
    builder.add_mimics()
    try:
        model = spec.compile()
    except ValueError as exc:  # MuJoCo's compiler says why in a ValueError
        raise SimError(f"MuJoCo cannot compile {emb.urdf_path}: {exc}") from exc
    floor = _lowest_point(model, emb)
    spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 1], pos=[0, 0, floor])
    table_z = None
    if table is not None:
        table_z = floor + float(table)
        spec.worldbody.add_geom(
            name="table", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 1], pos=[0, 0, table_z]
        )
    model = spec.compile()
    for note in notes:
        log.info("sim: %s", note)
    return _described(model, emb, gains, builder.parents, spatial, floor, table_z, notes)


class SimError(ValueError):
    """A robot that cannot be simulated; the message says why."""


def _urdf(emb: Embodiment) -> Any:
    import yourdfpy  # lazy: only a simulated robot needs its URDF parsed again

    if emb.urdf_path is None:
        raise SimError(f"robot '{emb.name}' has no URDF to simulate")
    return yourdfpy.URDF.load(
        str(emb.urdf_path), build_scene_graph=False, load_meshes=False, build_collision_scene_graph=False
    )


def _pose(matrix: np.ndarray | None) -> tuple[list[float], list[float]]:
    """(pos, quat w-x-y-z) of a 4x4 transform (identity for None)."""
    if matrix is None:
        return [0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(matrix[:3, :3], dtype=float).reshape(9))
    return [float(x) for x in matrix[:3, 3]], [float(x) for x in quat]


class _Builder:
    """Walks the URDF tree from its root link, adding bodies, joints, shapes and meshes to a spec."""

    def __init__(self, spec: Any, urdf: Any, folder: Path, gains: dict[str, Gains], notes: list[str]):
        self.spec, self.urdf, self.folder, self.gains, self.notes = spec, urdf, folder, gains, notes
        self.children: dict[str, list[Any]] = {}
        for joint in urdf.robot.joints:
            self.children.setdefault(joint.parent, []).append(joint)
        self.parents: dict[str, str | None] = {}
        self.ranges: dict[str, tuple[float, float]] = {}  # joint -> its URDF range, where bounded
        self.shaped: set[str] = set()  # links with shapes
        self._guessed_mass: list[str] = []
        self._visual_shapes: list[str] = []
        self._meshes = 0

    def root(self) -> str:
        children = {j.child for j in self.urdf.robot.joints}
        roots = [link.name for link in self.urdf.robot.links if link.name not in children]
        if len(roots) != 1:
            raise SimError(f"the URDF needs exactly one root link, found {roots}")
        self.parents[roots[0]] = None
        return roots[0]

    def add_link(self, body: Any, name: str) -> None:
        link = self.urdf.link_map[name]
        shapes = link.collisions or link.visuals
        if shapes:
            self.shaped.add(name)
        if shapes and not link.collisions:
            self._visual_shapes.append(name)
        for k, shape in enumerate(shapes):
            self._add_shape(body, f"{name}/{k}", shape)
        if link.inertial is not None and link.inertial.mass:
            pos, quat = _pose(link.inertial.origin)
            body.explicitinertial = True
            body.mass = float(link.inertial.mass)
            body.ipos, body.iquat = pos, quat
            i = link.inertial.inertia
            body.fullinertia = [i[0, 0], i[1, 1], i[2, 2], i[0, 1], i[0, 2], i[1, 2]]
        elif not shapes:
            body.explicitinertial = True
            body.mass = EMPTY_MASS
            body.inertia = [1e-8, 1e-8, 1e-8]
        else:
            self._guessed_mass.append(name)
        for joint in self.children.get(name, []):
            pos, quat = _pose(joint.origin)
            child = body.add_body(name=joint.child, pos=pos, quat=quat)
            self.parents[joint.child] = name
            self._add_joint(child, joint)
            self.add_link(child, joint.child)
        if self.parents[name] is None:
            self._say()

    def exclude_gimbals(self) -> None:
        """Links joined through shapeless links (a 3-axis neck's gimbal: neck -> yaw -> pitch -> head)
        touch where the joints are, like parent and child: MuJoCo filters only a body's own parent,
        so such pairs are excluded too, and said in the notes."""
        pairs = []
        for name in sorted(self.shaped):
            above = self.parents.get(name)
            skipped = False
            while above is not None and above not in self.shaped:
                above, skipped = self.parents.get(above), True
            if skipped and above is not None:
                self.spec.add_exclude(bodyname1=above, bodyname2=name)
                pairs.append(f"{above} / {name}")
        if pairs:
            self.notes.append(f"adjacent through shapeless links, never in contact: {', '.join(pairs)}")

    def _add_joint(self, body: Any, joint: Any) -> None:
        kinds = {"revolute": mujoco.mjtJoint.mjJNT_HINGE, "continuous": mujoco.mjtJoint.mjJNT_HINGE}
        kinds["prismatic"] = mujoco.mjtJoint.mjJNT_SLIDE
        if joint.type not in kinds:
            if joint.type != "fixed":
                self.notes.append(f"joint {joint.name} ({joint.type}) is simulated as fixed")
            return
        axis = joint.axis if joint.axis is not None else np.array([1.0, 0.0, 0.0])
        gains = self.gains.get(joint.name)
        armature = gains.armature if gains is not None else ARMATURE
        added = body.add_joint(name=joint.name, type=kinds[joint.type], axis=[float(a) for a in axis])
        added.armature = armature
        lower, upper = (joint.limit.lower, joint.limit.upper) if joint.limit is not None else (None, None)
        if joint.type != "continuous" and lower is not None and upper is not None and lower < upper:
            added.limited = mujoco.mjtLimited.mjLIMITED_TRUE
            added.range = [float(lower), float(upper)]
            self.ranges[joint.name] = (float(lower), float(upper))
        if joint.dynamics is not None:
            added.damping = float(joint.dynamics.damping or 0.0)
            added.frictionloss = float(joint.dynamics.friction or 0.0)

    def _add_shape(self, body: Any, name: str, shape: Any) -> None:
        pos, quat = _pose(shape.origin)
        g = shape.geometry
        kw: dict[str, Any] = {"name": name, "pos": pos, "quat": quat, "density": DENSITY}
        if g.box is not None:
            body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[s / 2 for s in g.box.size], **kw)
        elif g.cylinder is not None:
            size = [g.cylinder.radius, g.cylinder.length / 2, 0]
            body.add_geom(type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=size, **kw)
        elif g.sphere is not None:
            body.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[g.sphere.radius, 0, 0], **kw)
        elif g.mesh is not None:
            body.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname=self._mesh(g.mesh), **kw)

    def _mesh(self, mesh: Any) -> str:
        """A mesh asset for a URDF mesh (its file read by MuJoCo, or through trimesh); its name."""
        import yourdfpy  # lazy: only a URDF with meshes needs the resolver

        path = Path(yourdfpy.filename_handler_magic(mesh.filename, dir=str(self.folder)))
        if not path.is_file():
            raise SimError(f"mesh '{mesh.filename}' not found (looked for {path})")
        self._meshes += 1
        name = f"mesh{self._meshes}"
        scale = [float(s) for s in np.broadcast_to(np.asarray(mesh.scale or 1.0, dtype=float), (3,))]
        if path.suffix.lower() in _MUJOCO_MESHES:
            self.spec.add_mesh(name=name, file=str(path), scale=scale)
            return name
        import trimesh  # lazy: only meshes MuJoCo cannot read need it

        loaded: Any = trimesh.load(str(path), force="mesh")  # force="mesh": one Trimesh
        self.spec.add_mesh(
            name=name,
            uservert=np.asarray(loaded.vertices, dtype=float).reshape(-1).tolist(),
            userface=np.asarray(loaded.faces, dtype=int).reshape(-1).tolist(),
            scale=scale,
        )
        self.notes.append(f"mesh {path.name} read through trimesh ({len(loaded.faces)} faces)")
        return name

    def add_actuator(self, joint: str) -> None:
        g = self.gains[joint]
        act = self.spec.add_actuator(name=joint, target=joint, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        if g.kd is None:
            act.set_to_position(kp=g.kp, dampratio=1.0)
        else:
            act.set_to_position(kp=g.kp, kv=g.kd)
        act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
        act.forcerange = [-g.effort, g.effort]
        if joint in self.ranges:  # a goal beyond the range is one at its end, as a servo's limits make it
            act.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
            act.ctrlrange = list(self.ranges[joint])

    def add_mimics(self) -> None:
        for joint in self.urdf.robot.joints:
            if joint.mimic is None or joint.type == "fixed":
                continue
            multiplier = 1.0 if joint.mimic.multiplier is None else float(joint.mimic.multiplier)
            offset = 0.0 if joint.mimic.offset is None else float(joint.mimic.offset)
            eq = self.spec.add_equality(
                type=mujoco.mjtEq.mjEQ_JOINT, name1=joint.name, name2=joint.mimic.joint
            )
            eq.data[:5] = [offset, multiplier, 0.0, 0.0, 0.0]

    def _say(self) -> None:
        if self._guessed_mass:
            self.notes.append(
                f"inertia from geometry at {DENSITY:g} kg/m³ (no <inertial>): {', '.join(self._guessed_mass)}"
            )
        if self._visual_shapes:
            self.notes.append(f"visual shapes collide (no <collision>): {', '.join(self._visual_shapes)}")


def _lowest_point(model: Any, emb: Embodiment) -> float:
    """The lowest z (m) of the robot's shapes with its joints at rest: where the floor goes."""
    data = mujoco.MjData(model)
    rest = emb.joint_positions(emb.rest)
    for k, name in enumerate(emb.joint_names):
        data.qpos[model.jnt_qposadr[model.joint(name).id]] = rest[k]
    mujoco.mj_kinematics(model, data)
    low = math.inf
    for g in range(model.ngeom):
        low = min(low, _geom_bottom(model, data, g))
    return 0.0 if not math.isfinite(low) else float(low)


def _geom_bottom(model: Any, data: Any, g: int) -> float:
    """The lowest z of geom g (m) in its current pose."""
    r = data.geom_xmat[g].reshape(3, 3)
    z, size, kind = data.geom_xpos[g][2], model.geom_size[g], model.geom_type[g]
    if kind == mujoco.mjtGeom.mjGEOM_SPHERE:
        return z - size[0]
    if kind == mujoco.mjtGeom.mjGEOM_BOX:
        return z - float(np.abs(r[2]) @ size)
    if kind == mujoco.mjtGeom.mjGEOM_CYLINDER:
        c = abs(r[2, 2])
        return z - (c * size[1] + math.sqrt(max(0.0, 1.0 - c * c)) * size[0])
    if kind == mujoco.mjtGeom.mjGEOM_MESH:
        m = model.geom_dataid[g]
        start, count = model.mesh_vertadr[m], model.mesh_vertnum[m]
        verts = model.mesh_vert[start : start + count]
        return z + float(np.min(verts @ r[2]))
    return z - float(model.geom_rbound[g])


def _described(
    model: Any,
    emb: Embodiment,
    gains: dict[str, Gains],
    parents: dict[str, str | None],
    spatial: bool,
    floor: float,
    table_z: float | None,
    notes: list[str],
) -> SimModel:
    ids = [model.joint(n).id for n in emb.joint_names]
    return SimModel(
        model=model,
        joints=list(emb.joint_names),
        qpos_adr=np.array([model.jnt_qposadr[i] for i in ids], dtype=int),
        dof_adr=np.array([model.jnt_dofadr[i] for i in ids], dtype=int),
        effort=np.array([gains[n].effort for n in emb.joint_names]),
        gains=gains,
        body_links=[model.body(b).name for b in range(model.nbody)],
        parent_link=parents,
        base_mocap=int(model.body_mocapid[model.body(next(n for n, p in parents.items() if p is None)).id])
        if spatial
        else -1,
        floor_z=floor,
        table_z=table_z,
        notes=notes,
    )

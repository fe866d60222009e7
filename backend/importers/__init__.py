"""Import animation files as `nutty-clip/1` clips: glTF 2.0 (.gltf/.glb), BVH (.bvh) and CSV keys (.csv).

    from backend.importers import import_clip
    doc, report = import_clip("wave.glb", load_embodiment("nutty_desk"), mapping="map.json")

Each importer reads its file into source channels (`mapping.SourceChannel`) that carry their rest
pose; `mapping.resolve_channel` picks the robot DoF(s) of each (mapping file, exact DoF name, joint or
child-link name, then the same ignoring case and separators). A rotation channel then becomes angles:

1. its change from the rest (bind) pose, in the source's world axes: `pre * q * post` (glTF: the
   node's rest rotation, or the skin's inverse bind matrices; BVH: the OFFSET pose or --rest-frame);
2. in the robot's axes: conjugated by the up/forward conversion (`rotations.axis_conversion`; glTF
   and BVH are +Y up, --up z for files already +Z up; --forward names the source axis that faces
   the robot's +X);
3. reduced to the twist about the DoF's URDF axis in the robot's frame at rest (one DoF), or split
   into angles about two or three DoFs' axes in the listed order (`rotations.davenport`).
The rotation about other axes that this drops (the *swing*) is reported per channel, max and RMS;
above `swing_warn` degrees it is a warning suggesting the channel's principal axis.

Time: the clip's t = 0 is the animation's first frame. BVH frames start at 0; a glTF file names no
start frame (Blender writes frame / fps), so its first key becomes t = 0 and the report gives the
shift (`gltf_animations`). Channels the mapping file names that the imported glTF animation lacks
come from the one other animation that has them (Blender exports each action, e.g. shape keys, apart).

Keys: glTF STEP -> constant keys; sparse LINEAR keys -> linear keys (segments whose slerp is not
linear in the angle are sampled densely); *samples* (BVH frames, LINEAR keys at >= 20 Hz as exporters
write them) -> smooth bezier keys through them (`hermite_keys`: the cubic Hermite with the samples'
own slopes, exact at the kept samples, dropping those it reproduces within `tolerance`);
CUBICSPLINE rotations -> sampled densely, then smooth keys keeping the original keys; CUBICSPLINE
scalars/translations -> bezier keys with free handles from the Hermite tangents (right = [dt/3,
out*dt/3], left = [-dt_prev/3, -in*dt_prev/3]), exactly the same curve; CSV -> linear keys (or
`interp`), option names for enum DoFs. Values outside a DoF's limits are clamped.

Bad data (NaN/inf in a header, a frame, a quaternion) stops the import with one short message naming
the channel and the sample (index and time), unless `fill` repairs gaps of up to `max_gap` samples.
After clamping, the trajectory-helper (`limits.analyse_clip`) counts per DoF the samples over the
velocity, acceleration and jerk limits and says what the clip would need (`fit_limits` applies the
slow-down factor). The clip is validated and compiled against the robot before it is returned.

Modules: `sources` (the importers' interface and registry, reading files), `gltf_animations` (glTF
time zero, channels of other animations), `bad_data` (checks and repairs), `tracks` with `convert` and `keys` (channels -> DoF keys), `clip_warnings`, `report`, and
`pipeline` (the steps in order).

The file formats are importers (`sources.Importer`: name, suffixes, `read`), picked by the file's
suffix (or `--format`) from IMPORTERS, which holds those the `nutty.importers` entry points name (this
project's and installed plugin packages'; backend.plugins).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

# Everything below stays importable from `backend.importers`, as before the package was split.
from backend.importers.keys import SAMPLED_DT, decimate, hermite_keys  # noqa: F401 (public names)
from backend.importers.mapping import (  # noqa: F401 (public names)
    ChannelMap,
    ClipImportError,
    MappingSpec,
    SourceChannel,
    check_mapping,
    dof_axis,
    load_mapping,
    parse_mapping,
    resolve_channel,
)
from backend.importers.pipeline import FILL_MODES, MAX_DURATION, MAX_MESSAGE, run_import  # noqa: F401 (public names)
from backend.importers.report import format_report
from backend.importers.rotations import (  # noqa: F401 (public names)
    RotationError,
    axis_conversion,
    davenport,
    hemisphere,
    principal_axis,
    quat_angle,
    quat_conj,
    quat_mul,
    quat_normalise,
    slerp,
    swing_twist,
    twist_angle,
)
from backend.importers.sources import (
    FORMATS,
    IMPORTERS,
    Importer,
    ReadOptions,
    detect_format,
    read_channels,
    register_importer,
    reload,
)

reload()

__all__ = [
    "FORMATS",
    "IMPORTERS",
    "ClipImportError",
    "Importer",
    "ReadOptions",
    "SourceChannel",
    "decimate",
    "detect_format",
    "format_report",
    "hermite_keys",
    "import_clip",
    "read_channels",
    "register_importer",
    "reload",
    "swing_twist",
    "twist_angle",
]


def import_clip(
    path: str | Path, emb, mapping: str | Path | dict | MappingSpec | None = None, **options: Any
) -> tuple[dict[str, Any], dict[str, Any]]:
    """Import an animation file for robot `emb`: (clip document, report). Raises ClipImportError.
    Options: see `pipeline.run_import`. Absurd numbers in a file end in a ClipImportError, not in numpy
    warnings."""
    with np.errstate(over="ignore", invalid="ignore", divide="ignore", under="ignore"):
        return run_import(path, emb, mapping, **options)

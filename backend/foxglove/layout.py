"""The Foxglove layout for a Nutty robot (docs/foxglove/nutty-layout.json is this, for nutty_desk):

- a 3D panel with a URDF custom layer read from the `/robot_description` topic, posed by `/tf`
  (every link's transform), a grid, following the robot's root link within `odom` when it has a base;
- a Plot panel of a few `/joint_states` positions (rad or m) against the messages' header stamps;
- a Raw Messages panel on `/nutty/events`.

The file is in the format Foxglove's *Import from file…* reads (`configById` + a `layout` split tree);
the panels' configurations are made with the foxglove SDK's `foxglove.layouts` types, so their keys are
the app's own. Another robot's layout: `python -m backend.foxglove.layout ROBOT [FILE]`.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

from backend.engine.embodiment import Embodiment, load_embodiment
from backend.engine.kinematics import root_link

#: Joints plotted when the robot has them (else its first few): the ones that show an animation's shape.
PLOTTED = ("head_yaw", "head_pitch", "neck_pitch", "body_yaw", "ear_left")
_MAX_PLOTTED = 5
_THREE_D, _PLOT, _EVENTS = "3D!nutty", "Plot!nutty", "RawMessages!nutty"


def _config(model: Any) -> dict[str, Any]:
    """A `foxglove.layouts` config object as the app's JSON (unset fields left out)."""
    return json.loads(model.to_json())


def _three_d(emb: Embodiment, has_base: bool) -> dict[str, Any]:
    import foxglove.layouts as fl  # lazy: the optional foxglove extra

    base = root_link(emb) if emb.urdf_path is not None else "base_link"
    config = fl.ThreeDeeConfig(
        follow_tf=base,
        fixed_frame="odom" if has_base else base,
        follow_mode="follow-position",
        layers={
            "grid": fl.BaseRendererGridLayerSettings(
                instance_id="grid", label="Grid", frame_id="odom" if has_base else base, size=4, divisions=40
            ),
            "urdf": fl.BaseRendererUrdfLayerSettings(
                instance_id="urdf",
                layer_id="foxglove.Urdf",
                label=f"{emb.name} (URDF)",
                source_type="topic",
                topic="/robot_description",
                control_mode="transforms",
                display_mode="auto",
            ),
        },
        transforms={},
        topics={},
    )
    return _config(config)


def _plot(emb: Embodiment) -> dict[str, Any]:
    import foxglove.layouts as fl  # lazy: the optional foxglove extra

    names = list(emb.joint_names)
    chosen = [n for n in PLOTTED if n in names] or names[:_MAX_PLOTTED]
    series = [
        fl.PlotSeries(
            value=f"/joint_states.position[{names.index(n)}]",
            label=n,
            enabled=True,
            timestamp_method="headerStamp",
        )
        for n in chosen
    ]
    config = fl.PlotConfig(
        paths=series,
        x_axis_val="timestamp",
        following_view_width=10,
        show_legend=True,
        legend_display="floating",
        y_axis_label="rad",
    )
    return _config(config)


def _events() -> dict[str, Any]:
    import foxglove.layouts as fl  # lazy: the optional foxglove extra

    return _config(fl.RawMessagesConfig(topic_path="/nutty/events", expansion="all"))


def nutty_layout(emb: Embodiment) -> dict[str, Any]:
    """The layout (see the module doc) for `emb` as the JSON object Foxglove imports."""
    from backend.ros2.view import FrameView  # lazy: only to know whether the robot has a base

    has_base = FrameView(emb).has_base
    return {
        "configById": {_THREE_D: _three_d(emb, has_base), _PLOT: _plot(emb), _EVENTS: _events()},
        "globalVariables": {},
        "userNodes": {},
        "playbackConfig": {"speed": 1},
        "layout": {
            "direction": "row",
            "first": _THREE_D,
            "second": {"direction": "column", "first": _PLOT, "second": _EVENTS, "splitPercentage": 65},
            "splitPercentage": 55,
        },
    }


def layout_text(emb: Embodiment) -> str:
    """The layout file's text (indented, stable key order, trailing newline)."""
    return json.dumps(nutty_layout(emb), indent=2) + "\n"


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if not 1 <= len(args) <= 2:
        print("usage: python -m backend.foxglove.layout ROBOT [FILE]", file=sys.stderr)
        return 2
    text = layout_text(load_embodiment(args[0]))
    if len(args) == 2:
        Path(args[1]).write_text(text, encoding="utf-8")
    else:
        sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""The viser Pre-Viz posed from frames: joints resolved, ghost toggle, LEDs, captions, gaze input."""

from __future__ import annotations

import numpy as np
import pytest

from backend.engine.frames import FrameEvent
from backend.graph.builder import ProgramBuilder
from backend.session import EngineSession
from server_process import free_port


@pytest.fixture()
def previz(desk):
    from backend.previz import PreViz

    b = ProgramBuilder("gaze")
    b.expose("gaze_target", type="vec3", default=[1.0, 0.0, 0.3])
    b.chain(b.node("sine", "s", dofs=["head_yaw"], amplitude=0.3), b.node("nmf_stage2", "nmf"), b.output())
    session = EngineSession.create(desk, rate=100, program=b.build())
    pv = PreViz(session, port=free_port())
    yield pv
    pv.stop()
    session.engine.close()


def test_frames_pose_robot_leds_face_and_captions(previz, desk):
    session = previz.session
    frame = None
    for frame in session.run_headless(30):
        pass
    frame.position[desk.dof("eye_leds").channels] = [1.0, 0.0, 0.5]
    frame.position[desk.dof("mouth").channels] = 1
    frame.events = [FrameEvent("speech", "say", {"text": "hello there"})]
    previz.show(frame)
    cfg = previz._cfg(frame.position)
    names = previz.robot.get_actuated_joint_names()
    assert cfg[names.index("head_yaw")] == pytest.approx(frame.position[desk.channel_index["head_yaw"]])
    assert all(h.color == (255, 0, 128) for h in previz._leds[0][1])
    assert previz._face[2].text == "smile"
    assert "hello there" in previz._caption.text


def test_ghost_toggle_and_sink_decimation(previz):
    previz.set_ghost(False)
    assert not previz.ghost_visible and previz.ghost_toggle.value is False
    previz.set_ghost(True)
    assert previz.ghost_visible
    previz.start()
    sink = previz._sink
    assert sink.decimate == 2  # 100 Hz engine -> at most 60 Hz to viser
    previz.session.engine.run_ticks(40)
    previz.session.engine.close()
    assert previz.frames_shown >= 1


def test_dragging_the_gaze_target_sets_the_input(previz):
    previz.gaze.position = np.array([0.5, 0.2, 0.4])
    previz._on_gaze_drag()
    previz.session.engine.tick()
    assert previz.session.inputs()["gaze_target"] == pytest.approx([0.5, 0.2, 0.4])

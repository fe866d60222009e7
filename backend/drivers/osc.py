"""UDP/OSC output (python-osc) for robots and show-control tools that speak OSC.

One OSC bundle per frame, time-tagged with the wall-clock time it is sent (NTP, as OSC defines), holding:

- `<prefix>/frame <seq> <t> <dt>`: the frame's sequence number (int), engine time and tick (s);
- `<prefix>/<dof> <value>` for continuous and enum DoFs, `<prefix>/<dof> r g b` for colours;
- `<prefix>/joint/<joint> <value>` for each actuated URDF joint (rad or m): what a motor must get,
  symbolic DoFs resolved and limited by the engine's safety net (a joint that only symbolic DoFs
  drive is limited here and nowhere in the channels);
- `<prefix>/<dof>/<kind> <payload>` for events (speech text, sound name); an event that plays a file
  of the robot's sounds adds `<url> <t>`: where to fetch it (relative to the server) and its start in
  frame time (s) (docs/drivers.md, *Audio events*).
"""

from __future__ import annotations

import time

from backend.drivers.registry import DriverOption, host_port
from backend.engine.embodiment import DofType, Embodiment
from backend.engine.frames import AnimationFrame
from backend.engine.runtime import Sink


class OscDriver(Sink[AnimationFrame]):
    option = DriverOption(
        "osc", metavar="HOST:PORT", parse=host_port, help="also send every frame as OSC to HOST:PORT"
    )

    def __init__(
        self,
        embodiment: Embodiment,
        host: str = "127.0.0.1",
        port: int = 9000,
        prefix: str = "/nutty",
        decimate: int = 1,
    ):
        from pythonosc.udp_client import SimpleUDPClient  # only for an OSC driver: every driver loads

        if not 0 < port < 65536:
            raise ValueError(f"OSC port must be within 1..65535, got {port}")
        self.emb = embodiment
        self.prefix = prefix.rstrip("/")
        self.client = SimpleUDPClient(host, port)
        super().__init__(f"osc:{host}:{port}", max_queue=4, decimate=decimate)

    @classmethod
    def from_option(cls, embodiment: Embodiment, address: tuple[str, int]) -> OscDriver:
        host, port = address
        return cls(embodiment, host, port)

    def consume(self, frame: AnimationFrame) -> None:
        from pythonosc.osc_bundle_builder import OscBundleBuilder  # python-osc: see __init__
        from pythonosc.osc_message_builder import OscMessageBuilder  # python-osc: see __init__

        now = time.time()  # the OSC time tag: float seconds since the epoch, as python-osc documents
        bundle = OscBundleBuilder(now)  # pyright: ignore[reportArgumentType]  # its annotation says int
        head = OscMessageBuilder(address=f"{self.prefix}/frame")
        head.add_arg(int(frame.seq))
        head.add_arg(float(frame.t))
        head.add_arg(float(frame.dt))
        bundle.add_content(head.build())
        for d in self.emb.dofs:
            if d.type is DofType.event:
                continue
            msg = OscMessageBuilder(address=f"{self.prefix}/{d.name}")
            for v in frame.position[d.channels]:
                msg.add_arg(round(v) if d.type is DofType.enum else float(v))
            bundle.add_content(msg.build())
        for name, q in zip(self.emb.joint_names, frame.joint_values(self.emb).tolist()):
            msg = OscMessageBuilder(address=f"{self.prefix}/joint/{name}")
            msg.add_arg(float(q))
            bundle.add_content(msg.build())
        for ev in frame.events:
            msg = OscMessageBuilder(address=f"{self.prefix}/{ev.dof}/{ev.kind}")
            msg.add_arg(
                str(ev.payload.get("text") or ev.payload.get("clip") or ev.payload.get("sound") or "")
            )
            if isinstance(ev.payload.get("url"), str):
                msg.add_arg(ev.payload["url"])
                msg.add_arg(float(ev.payload.get("t", frame.t)))
            bundle.add_content(msg.build())
        self.client.send(bundle.build())

"""Nutty on Zenoh: engines publish under `nutty/<robot id>/`, a fleet lists and commands them, a
robot-side bridge follows one robot's frames (docs/fleet.md).

- `keys`: the key layout and robot ids;
- `session`: the shared command-line options and opening a session;
- `codec`: JSON and msgpack on the wire, the robot and frames back from their documents;
- `engine`: `EngineLink`, an engine's presence (`nutty serve --zenoh`);
- `serve`: the `nutty serve` options and wiring;
- `follow`: `ZenohFeed`, a robot's frames into a bridge (`nutty bridge`).

The fleet client is `backend.fleet.Fleet`; the bridge's transport-free core is `backend.bridge`.
"""

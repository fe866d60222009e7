"""Foxglove: the live WebSocket server driver (`--foxglove PORT`, server.py), the per-frame link
transforms it publishes (transforms.py), the robot's meshes for the viewer (assets.py) and the layout
that shows them (layout.py)."""

# Loading backend.drivers registers every driver entry point, this package's server among them; done
# first, so that importing backend.foxglove.server on its own does not meet its own half-run module
# through the registry (a circular import).
import backend.drivers  # noqa: F401 (imported for its registration side effect, see above)

"""The physics preview: the robot's URDF in MuJoCo, following the engine's frames (docs/simulation.md).

`backend.sim.model` compiles the URDF, `backend.sim.world` steps it and finds contacts,
`backend.sim.driver` is `nutty serve --sim mujoco`, `backend.sim.report` is `nutty sim report`.
MuJoCo is an optional extra (`pip install -e ".[sim]"`; `make run` and `make test` install it):
`require_mujoco()` says how to get it when it is missing.
"""

# The drivers' registry loads every `nutty.drivers` entry point, this package's among them, when it is
# first imported: import it before this package's modules start to, so none is half-imported then.
import backend.drivers  # noqa: F401 (imported for its registration side effect, see above)
from backend.sim.availability import SimUnavailable, require_mujoco

__all__ = ["SimUnavailable", "require_mujoco"]

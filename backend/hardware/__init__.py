"""Real servos: Dynamixel (Protocol 2.0), Feetech STS/SCS and PCA9685 PWM boards, configured by a
robot's hardware.yaml and driven by `nutty serve --hardware FILE` (docs/hardware.md).

Each bus kind is a `ServoBus` class registered under the `nutty.hardware` entry-point group, named after
its `driver:` word; `backend.hardware.registry.BUSES` holds them.
"""

# The drivers' registry loads every `nutty.drivers` entry point, this package's among them, when it is
# first imported: import it before this package's modules start to, so none is half-imported then.
import backend.drivers  # noqa: F401 (imported for its registration side effect, see above)

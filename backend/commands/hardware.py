"""`nutty hardware`: the real servos' tools — `scan` a bus, `check` a hardware file against the robot,
`calibrate` a joint's zero and direction (docs/hardware.md)."""

from __future__ import annotations

import argparse
import json
import sys

from backend.commands._common import fail
from backend.engine.embodiment import DEFAULT_ROBOT, EmbodimentError, load_embodiment


def _ids(text: str) -> range:
    """`A-B` (inclusive) or one id, within 0..252."""
    lo, _, hi = text.partition("-")
    try:
        first, last = int(lo), int(hi or lo)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an id or a range A-B, got {text!r}") from None
    if not 0 <= first <= last <= 252:
        raise argparse.ArgumentTypeError(f"ids are within 0..252, got {text!r}")
    return range(first, last + 1)


def register(sub) -> None:
    p = sub.add_parser("hardware", help="real servos: scan a bus, check a hardware file, calibrate a joint")
    tools = p.add_subparsers(dest="tool", metavar="TOOL", required=True)

    scan = tools.add_parser("scan", help="list the servos on a serial bus (id, model, position)")
    scan.add_argument("--port", required=True, help="the serial device, e.g. /dev/ttyUSB0")
    scan.add_argument("--driver", default="dynamixel", help="the bus kind: dynamixel (default) or feetech")
    scan.add_argument("--baudrate", type=int, default=1_000_000, help="bits per second (default 1000000)")
    scan.add_argument("--series", choices=["sts", "scs"], default="sts", help="Feetech series (default sts)")
    scan.add_argument("--ids", type=_ids, default=range(253), help="ids to try: N or A-B (default 0-252)")
    scan.add_argument("--json", action="store_true", help="print JSON instead of a table")
    scan.set_defaults(func=run_scan)

    check = tools.add_parser("check", help="check a hardware file against the robot (no servo is moved)")
    check.add_argument("file", help="the hardware file, e.g. robots/nutty_desk/hardware.yaml")
    check.add_argument("--robot", default=DEFAULT_ROBOT, help="robot folder, URDF file or bundled robot name")
    check.set_defaults(func=run_check)

    cal = tools.add_parser(
        "calibrate",
        help="set a joint's zero and direction by moving it by hand, and write the file",
        description="Switches the joint's servo torque off, asks you to hold the joint at 0 rad, then at a "
        "positive angle, and writes zero and direction into the file (the old one kept as FILE.bak).",
    )
    cal.add_argument("file", help="the hardware file to update")
    cal.add_argument("--joint", required=True, help="the URDF joint to calibrate")
    cal.add_argument("--robot", default=DEFAULT_ROBOT, help="robot folder, URDF file or bundled robot name")
    cal.add_argument(
        "--angle",
        type=float,
        default=None,
        help="the second pose's angle (rad, > 0; default: half the upper limit)",
    )
    cal.add_argument("--gear", action="store_true", help="also write the gear the two poses measure")
    cal.set_defaults(func=run_calibrate)


def run_scan(args) -> int:
    from backend.hardware.bus import HardwareError  # lazy: the SDKs load only for the hardware tools
    from backend.hardware.tools import scan  # lazy: likewise

    try:
        found = scan(args.driver, args.port, args.baudrate, args.ids, series=args.series)
    except HardwareError as exc:
        return fail(str(exc))
    if args.json:
        rows = [
            {"id": s.id, "model": s.model, "model_name": s.model_name, "position": s.position} for s in found
        ]
        print(json.dumps({"port": args.port, "driver": args.driver, "servos": rows}))
        return 0
    print(f"{len(found)} servo(s) on {args.port} ({args.driver}, {args.baudrate} baud)")
    for s in found:
        position = "?" if s.position is None else f"{s.position:.0f}"
        print(f"  id {s.id:3d}  {s.model_name:<14s} (model {s.model})  position {position} ticks")
    return 0 if found else 1


def _robot_and_file(args):
    from backend.hardware.config import HardwareConfigError, load_hardware  # lazy: a fast `nutty --help`

    try:
        emb = load_embodiment(args.robot)
        return emb, load_hardware(args.file, emb)
    except (EmbodimentError, HardwareConfigError) as exc:
        return fail(str(exc))


def run_check(args) -> int:
    loaded = _robot_and_file(args)
    if isinstance(loaded, int):
        return loaded
    emb, hardware = loaded
    from backend.hardware.config import raw_unit  # lazy: a fast `nutty --help`
    from backend.hardware.mapping import JointMap  # lazy: a fast `nutty --help`

    print(f"{args.file}: {len(hardware.buses)} bus(es) for {emb.name}")
    for config in hardware.buses:
        jmap = JointMap(config, emb)
        unit = raw_unit(config)
        print(f"  {config.driver} on {getattr(config, 'port', '?')}")
        lo, hi = jmap.urdf_span()
        for k, name in enumerate(jmap.names):
            print(
                f"    {name:<14s} id {jmap.ids[k]:3d}  [{jmap.lower[k]:g}, {jmap.upper[k]:g}] rad -> "
                f"[{lo[k]:.0f}, {hi[k]:.0f}] {unit}"
            )
    return 0


def run_calibrate(args) -> int:
    loaded = _robot_and_file(args)
    if isinstance(loaded, int):
        return loaded
    emb, hardware = loaded
    from backend.hardware.bus import HardwareError  # lazy: the SDKs load only for the hardware tools
    from backend.hardware.tools import Calibration  # lazy: likewise

    upper = {j.name: j.upper for j in emb.joints}.get(args.joint)
    angle = args.angle if args.angle is not None else (upper / 2 if upper and upper > 0 else 0.5)
    try:
        cal = Calibration(hardware, emb, args.joint)
        cal.start()
    except HardwareError as exc:
        return fail(str(exc))
    try:
        input(f"Torque is off on {args.joint}. Hold it at 0 rad (its rest pose) and press Enter… ")
        zero = cal.at_zero()
        print(f"  zero: {zero:.0f} ticks")
        input(f"Now turn {args.joint} to +{angle:g} rad (its positive direction) and press Enter… ")
        zero, direction, gear = cal.at_positive(angle)
        print(f"  direction: {direction:+d}   gear measured: {gear:.2f}")
        path = cal.write(keep_gear=not args.gear)
    except (HardwareError, EOFError) as exc:
        return fail(str(exc) or "calibration cancelled")
    finally:
        cal.close()
    print(f"wrote {path} (the previous file is {path}.bak)", file=sys.stdout)
    return 0

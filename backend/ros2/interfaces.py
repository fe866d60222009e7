"""ROS 2 interface packages the Kilted wheels lack, built into the virtualenv this runs from.

The `[ros2]` wheels have no `tf2_msgs`, which a live link needs for the base pose on `/tf`, but ship
the rosidl toolchain: `python -m backend.ros2.interfaces build` generates tf2_msgs from its standard
definition (interfaces/tf2_msgs/msg/TFMessage.msg) and compiles it with the system C/C++ compiler,
laid out as the wheels lay out their own packages:

- `lib/libtf2_msgs__rosidl_{generator_c,typesupport_c,typesupport_fastrtps_c,
  typesupport_introspection_c,generator_py}.so` (found through LD_LIBRARY_PATH, which the wheels'
  bootstrapper sets to `<venv>/lib`, and an rpath of their own),
- `site-packages/tf2_msgs/` (the Python message classes and their C extension),
- the definitions under `share/tf2_msgs/msg/` and the ament index,
- `site-packages/nutty_tf2_msgs-<version>.dist-info` with a RECORD, so `pip uninstall nutty-tf2-msgs`
  removes all of it.

Everything is built in a temporary directory first and copied in only when every step succeeded; a
failed copy or a failed import check afterwards removes what was copied. A second run with the same
inputs does nothing. Only what Python needs is built: the C type supports (rclpy and rmw_fastrtps_cpp
use those), no C++ type supports and no headers.
"""

from __future__ import annotations

import argparse
import base64
import contextlib
import fcntl
import hashlib
import io
import json
import logging
import os
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import time
from collections.abc import Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path

#: Where the interface definitions of the packages built here live (one folder per package).
DEFINITIONS = Path(__file__).with_name("interfaces")
#: The RIHS01 type hash of the standard tf2_msgs/msg/TFMessage, which Kilted exchanges in discovery
#: (as ROS's own build and `rosbags` compute it); a build whose generated hash differs is refused.
TFMESSAGE_TYPE_HASH = "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087"


@dataclass(frozen=True)
class InterfacePackage:
    """A message package to build: its name, messages, the packages its messages use."""

    name: str
    messages: tuple[str, ...]
    dependencies: tuple[str, ...]
    type_hashes: dict[str, str]
    version: str = "1.0.0"

    @property
    def distribution(self) -> str:
        """The pip distribution name the build is recorded under (not ROS's own `ros-tf2-msgs`)."""
        return f"nutty-{self.name.replace('_', '-')}"


TF2_MSGS = InterfacePackage(
    name="tf2_msgs",
    messages=("TFMessage",),
    dependencies=("geometry_msgs", "std_msgs", "builtin_interfaces"),
    type_hashes={"tf2_msgs/msg/TFMessage": TFMESSAGE_TYPE_HASH},
)

#: Header folders under `<venv>/include/` that must be there (every folder there is searched).
_INCLUDE_DIRS = ("rosidl_runtime_c", "rosidl_typesupport_fastrtps_c", "rmw", "fastcdr")
#: Runtime libraries under `<venv>/lib/` the built libraries link against.
_RUNTIME_LIBS = (
    "rosidl_runtime_c",
    "rosidl_typesupport_c",
    "rosidl_typesupport_fastrtps_c",
    "fastcdr",
    "rmw",
)
_RUNTIME_LIBS += ("rosidl_typesupport_fastrtps_cpp", "rosidl_typesupport_introspection_c", "rcutils")
#: Generator name -> its rosidl CLI extension; the extension's package names the library layer
#: (`lib<pkg>__<layer>.so`) its code goes into.
_GENERATORS = {
    "c": "rosidl_generator_c.cli:GenerateC",
    "typesupport_c": "rosidl_typesupport_c.cli:GenerateCTypesupport",
    "typesupport_fastrtps_c": "rosidl_typesupport_fastrtps_c.cli:GenerateFastRTPSCTypesupport",
    "typesupport_introspection_c": "rosidl_typesupport_introspection_c.cli:GenerateIntrospectionCTypesupport",
    "py": "rosidl_generator_py.cli:GeneratePython",
}
_LAYERS = {name: spec.split(".")[0] for name, spec in _GENERATORS.items()}


class InterfaceBuildError(RuntimeError):
    """The build cannot go on; the message says which step failed and what is missing."""


@dataclass(frozen=True)
class BuildResult:
    """What `build` did: `status` is "built" or "up to date"; `seconds` is wall time in seconds."""

    status: str
    seconds: float
    files: tuple[Path, ...]


@dataclass(frozen=True)
class _Layout:
    """Where things go in a prefix (the virtualenv, or the staging copy of it)."""

    prefix: Path
    site: Path


def venv_layout() -> _Layout:
    """The running interpreter's prefix and its site-packages (platlib) folder."""
    return _Layout(Path(sys.prefix), Path(sysconfig.get_path("platlib")))


def missing_prerequisites(pkg: InterfacePackage, layout: _Layout) -> list[str]:
    """Everything the build needs that this machine lacks, as readable lines (empty when all is there)."""
    missing = [
        f"a {what} compiler ({os.environ.get(env, cmd)} on PATH, or set ${env})"
        for what, env, cmd in (("C", "CC", "gcc"), ("C++", "CXX", "g++"))
        if not shutil.which(os.environ.get(env, cmd))
    ]
    python_h = Path(sysconfig.get_paths()["include"]) / "Python.h"
    if not python_h.is_file():
        missing.append(f"Python headers ({python_h}; install python3-dev)")
    for module in ("numpy", *_LAYERS.values(), "rosidl_adapter"):
        try:
            __import__(module)
        except ImportError:
            missing.append(f"the Python module {module} (pip install -e '.[ros2]')")
    include = layout.prefix / "include"
    missing += [
        f"headers {include / d}" for d in (*_INCLUDE_DIRS, *pkg.dependencies) if not (include / d).is_dir()
    ]
    lib = layout.prefix / "lib"
    layers = [layer for layer in _LAYERS.values() if layer != "rosidl_typesupport_c"]
    needed = [*_RUNTIME_LIBS, *(f"{d}__{layer}" for d in pkg.dependencies for layer in layers)]
    missing += [f"library {lib}/lib{name}.so" for name in needed if not (lib / f"lib{name}.so").is_file()]
    definitions = [layout.prefix / "share" / d / "msg" for d in pkg.dependencies]
    missing += [f"interface definitions {folder}" for folder in definitions if not folder.is_dir()]
    missing += [f"definition {m}" for m in _definition_files(pkg) if not m.is_file()]
    return missing


def _definition_files(pkg: InterfacePackage) -> list[Path]:
    return [DEFINITIONS / pkg.name / "msg" / f"{m}.msg" for m in pkg.messages]


def inputs_digest(pkg: InterfacePackage) -> str:
    """A digest of what the built files depend on: the definitions, the toolchain's versions, Python's."""
    h = hashlib.sha256()
    for path in _definition_files(pkg):
        h.update(path.name.encode() + b"\0" + path.read_bytes() + b"\0")
    # The versions of the generators and of the packages the messages use change the generated code.
    for dist in (f"ros-{name}".replace("_", "-") for name in (*_LAYERS.values(), *pkg.dependencies)):
        try:
            h.update(f"{dist}={metadata.version(dist)}\0".encode())
        except metadata.PackageNotFoundError:
            h.update(f"{dist}=?\0".encode())
    h.update(f"{pkg.version} {sys.version_info[:2]} {sysconfig.get_platform()}".encode())
    return h.hexdigest()


@contextlib.contextmanager
def _generator_environment(prefix: Path) -> Iterator[None]:
    """The generators find their templates through the ament index: point it at the venv for a while.
    rosidl_cli warns about each entry point the wheels register twice (egg-info and dist-info): hush."""
    old = os.environ.get("AMENT_PREFIX_PATH")
    os.environ["AMENT_PREFIX_PATH"] = os.pathsep.join(p for p in (str(prefix), old) if p)
    cli_log = logging.getLogger("rosidl_cli")
    level = cli_log.level
    cli_log.setLevel(logging.ERROR)
    try:
        yield
    finally:
        cli_log.setLevel(level)
        if old is None:
            os.environ.pop("AMENT_PREFIX_PATH", None)
        else:
            os.environ["AMENT_PREFIX_PATH"] = old


def generate(pkg: InterfacePackage, layout: _Layout, build: Path) -> Path:
    """Translate the .msg files to .idl and run the rosidl generators; returns the generated tree.

    `<build>/gen/<generator>/<package>/...` holds each generator's output (as `#include` expects it).
    """
    # lazy: the rosidl toolchain comes with the [ros2] extra, needed only when building
    from rosidl_adapter.msg import convert_msg_to_idl

    source = build / "src" / pkg.name
    (source / "msg").mkdir(parents=True)
    quiet = io.StringIO()
    for msg in _definition_files(pkg):
        shutil.copy2(msg, source / "msg" / msg.name)
        with contextlib.redirect_stdout(quiet):  # it prints each file it reads and writes
            convert_msg_to_idl(source, pkg.name, Path("msg") / msg.name, source / "msg")
    idl_files = [f"{source}:msg/{m}.idl" for m in pkg.messages]
    includes = [str(layout.prefix / "share" / d) for d in pkg.dependencies]
    gen = build / "gen"
    # Python's C extension is built for the C type supports only (those in _LAYERS).
    typesupports = [layer for layer in _LAYERS.values() if layer.startswith("rosidl_typesupport")]
    with _generator_environment(layout.prefix), contextlib.redirect_stdout(quiet):
        for name, spec in _GENERATORS.items():
            module, _, cls = spec.partition(":")
            factory = getattr(__import__(module, fromlist=[cls]), cls)
            py = name == "py"
            extension = factory(name, typesupport_implementations=typesupports) if py else factory(name)
            extension.generate(pkg.name, idl_files, includes, output_path=gen / name / pkg.name)
    _check_type_hashes(pkg, gen / "c" / pkg.name / "msg")
    return gen


def _check_type_hashes(pkg: InterfacePackage, msg_dir: Path) -> None:
    for typename, expected in pkg.type_hashes.items():
        described = json.loads((msg_dir / f"{typename.rsplit('/', 1)[1]}.json").read_text())
        got = next(h["hash_string"] for h in described["type_hashes"] if h["type_name"] == typename)
        if got != expected:
            raise InterfaceBuildError(
                f"generated {typename} has type hash {got}, the standard one is {expected}: "
                "its definition or a dependency differs from ROS 2 Kilted's; not installing"
            )


@dataclass(frozen=True)
class _Library:
    """One shared object to compile: `output` relative to the staging prefix, `links` are -l names."""

    output: Path
    sources: tuple[Path, ...]
    links: tuple[str, ...]
    rpath: str
    python: bool = False


def _libraries(pkg: InterfacePackage, layout: _Layout, gen: Path) -> list[list[_Library]]:
    """The libraries in build order: each inner list may be compiled at the same time.

    Each `lib<pkg>__<layer>.so` holds one generator's sources and links the same layer of the
    packages its messages use (the C type support dispatches at run time, so it links none of them).
    """
    n, deps = pkg.name, pkg.dependencies
    base = (*(f"{d}__rosidl_generator_c" for d in deps), *_RUNTIME_LIBS)

    def lib(name: str, pattern: str, *links: str) -> _Library:
        layer = _LAYERS[name]
        uses = [] if layer == "rosidl_typesupport_c" else [f"{d}__{layer}" for d in deps]
        own = [] if name == "c" else [f"{n}__rosidl_generator_c"]
        sources = tuple(sorted((gen / name / n / "msg").glob(pattern)))
        return _Library(Path("lib") / f"lib{n}__{layer}.so", sources, (*links, *own, *uses, *base), "$ORIGIN")

    site = layout.site.relative_to(layout.prefix)
    # From <site>/<package>/ up to the prefix, then into its lib/.
    up = "/".join([".."] * (len(site.parts) + 1))
    extension = _Library(
        site / n / f"{n}_s__rosidl_typesupport_c.so",
        (gen / "py" / n / f"_{n}_s.ep.rosidl_typesupport_c.c",),
        (f"{n}__rosidl_generator_py", f"{n}__rosidl_typesupport_c", f"{n}__rosidl_generator_c", *base),
        f"$ORIGIN/{up}/lib",
        python=True,
    )
    py = lib("py", "*_s.c", f"{n}__rosidl_typesupport_c")
    return [
        [lib("c", "detail/*.c")],
        [
            lib("typesupport_c", "*.cpp"),
            lib("typesupport_fastrtps_c", "detail/*.cpp"),
            lib("typesupport_introspection_c", "detail/*.c"),
        ],
        [_Library(py.output, py.sources, py.links, py.rpath, python=True)],
        [extension],
    ]


def _compile(library: _Library, layout: _Layout, gen: Path, stage: Path) -> None:
    """Compile and link one shared object into the staging tree; raises naming the failing library."""
    cxx = any(s.suffix == ".cpp" for s in library.sources)
    compiler = os.environ.get("CXX", "g++") if cxx else os.environ.get("CC", "gcc")
    include = layout.prefix / "include"
    includes = [gen / "c", gen / "typesupport_fastrtps_c", gen / "typesupport_introspection_c", include]
    # The wheels put each package's headers in include/<package>/<package>/: search them all.
    includes += sorted(p for p in include.iterdir() if p.is_dir())
    if library.python:
        # lazy: numpy is only needed for the headers of the Python message conversions
        import numpy

        includes += [Path(sysconfig.get_paths()["include"]), Path(numpy.get_include())]
    output = stage / library.output
    output.parent.mkdir(parents=True, exist_ok=True)
    command = [compiler, "-shared", "-fPIC", "-O2", "-w", *(["-std=c++17"] if cxx else [])]
    command += [f"-I{p}" for p in includes] + [str(s) for s in library.sources]
    command += [f"-L{stage / 'lib'}", f"-L{layout.prefix / 'lib'}", f"-Wl,-rpath,{library.rpath}"]
    # Python's own symbols come from the interpreter that loads the module, so only others must resolve.
    command += [] if library.python else ["-Wl,--no-undefined"]
    command += [f"-l{name}" for name in library.links] + ["-o", str(output)]
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise InterfaceBuildError(
            f"compiling {library.output.name} failed: {' '.join(command)}\n{done.stderr}"
        )


def _stage_files(pkg: InterfacePackage, layout: _Layout, gen: Path, build: Path, stage: Path) -> None:
    """Put the Python package, the definitions and ament index entries into the staging tree."""
    n = pkg.name
    site = stage / layout.site.relative_to(layout.prefix) / n
    (site / "msg").mkdir(parents=True, exist_ok=True)
    (site / "__init__.py").write_text("")
    for py in (gen / "py" / n / "msg").glob("*.py"):
        shutil.copy2(py, site / "msg" / py.name)
    share = stage / "share" / n / "msg"
    share.mkdir(parents=True, exist_ok=True)
    interfaces = []
    for m in pkg.messages:
        for suffix, src in ((".msg", build / "src"), (".idl", build / "src"), (".json", gen / "c")):
            shutil.copy2(src / n / "msg" / f"{m}{suffix}", share / f"{m}{suffix}")
        interfaces += [f"msg/{m}.idl", f"msg/{m}.msg"]
    index = stage / "share" / "ament_index" / "resource_index"
    for kind, text in (("packages", ""), ("rosidl_interfaces", "\n".join(interfaces))):
        (index / kind).mkdir(parents=True, exist_ok=True)
        (index / kind / n).write_text(text)


def _dist_info(pkg: InterfacePackage, layout: _Layout) -> Path:
    return layout.site / f"{pkg.distribution.replace('-', '_')}-{pkg.version}.dist-info"


def installed_files(pkg: InterfacePackage, layout: _Layout) -> list[Path] | None:
    """The files a previous build installed (from its RECORD), or None when none is recorded."""
    for record in layout.site.glob(f"{pkg.distribution.replace('-', '_')}-*.dist-info/RECORD"):
        rows = [line.split(",")[0] for line in record.read_text().splitlines() if line.strip()]
        return [(layout.site / row).resolve() for row in rows]
    return None


def _installed_digest(pkg: InterfacePackage, layout: _Layout) -> str | None:
    files = installed_files(pkg, layout)
    if files is None or not all(f.exists() for f in files):
        return None
    build_json = _dist_info(pkg, layout) / "nutty_build.json"
    return json.loads(build_json.read_text()).get("inputs") if build_json.is_file() else None


def _remove(files: Sequence[Path], prefix: Path) -> None:
    """Delete `files`, our modules' bytecode, and the folders under `prefix` this leaves empty."""
    for path in files:
        path.unlink(missing_ok=True)
    for folder in {p.parent for p in files if p.suffix == ".py"}:
        shutil.rmtree(folder / "__pycache__", ignore_errors=True)
    folders = {d for p in files for d in p.parents if prefix in d.parents}
    for folder in sorted(folders, key=lambda p: len(p.parts), reverse=True):
        with contextlib.suppress(OSError):  # not empty: it holds other packages' files too
            folder.rmdir()


def _install(pkg: InterfacePackage, layout: _Layout, stage: Path, digest: str) -> list[Path]:
    """Copy the staged tree into the prefix with a dist-info RECORD; on any failure remove what was copied."""
    staged = sorted(p for p in stage.rglob("*") if p.is_file())
    targets = [layout.prefix / p.relative_to(stage) for p in staged]
    dist_info = _dist_info(pkg, layout)
    meta = {
        "METADATA": f"Metadata-Version: 2.1\nName: {pkg.distribution}\nVersion: {pkg.version}\n"
        f"Summary: ROS 2 {pkg.name} built from its standard definition by backend/ros2/interfaces.py\n",
        "INSTALLER": "nutty\n",
        "nutty_build.json": json.dumps({"inputs": digest, "package": pkg.name}) + "\n",
    }
    written: list[Path] = []
    try:
        for src, dst in zip(staged, targets, strict=True):
            dst.parent.mkdir(parents=True, exist_ok=True)
            tmp = dst.with_name(f".{dst.name}.nutty-tmp")
            written.append(tmp)
            shutil.copy2(src, tmp)
            os.replace(tmp, dst)  # atomic per file: a running process never sees half a library
            written[-1] = dst
        dist_info.mkdir(parents=True, exist_ok=True)
        for name, text in meta.items():
            (dist_info / name).write_text(text)
            written.append(dist_info / name)
        record = dist_info / "RECORD"
        written.append(record)
        rows = [_record_row(path, layout.site) for path in written if path != record]
        record.write_text("\n".join([*rows, f"{os.path.relpath(record, layout.site)},,"]) + "\n")
    except OSError as exc:
        _remove(written, layout.prefix)
        raise InterfaceBuildError(
            f"installing into {layout.prefix} failed ({exc}); removed its files"
        ) from exc
    return written


def _record_row(path: Path, site: Path) -> str:
    digest = base64.urlsafe_b64encode(hashlib.sha256(path.read_bytes()).digest()).rstrip(b"=").decode()
    return f"{os.path.relpath(path, site)},sha256={digest},{path.stat().st_size}"


#: Run in a fresh interpreter after installing: the classes import, and a message survives the rmw's
#: serialisation (rosidl_typesupport_c dispatching to the installed fastrtps_c library) both ways.
_VERIFY = """
from geometry_msgs.msg import TransformStamped
from rclpy.serialization import deserialize_message, serialize_message
from tf2_msgs.msg import TFMessage
t = TransformStamped(child_frame_id="base_link")
t.header.frame_id = "odom"
t.transform.translation.x = 1.25
back = deserialize_message(serialize_message(TFMessage(transforms=[t])), TFMessage)
if back.transforms[0].transform.translation.x != 1.25 or back.transforms[0].child_frame_id != "base_link":
    raise SystemExit("round trip changed the message")
"""


def _verify(pkg: InterfacePackage) -> None:
    if pkg is not TF2_MSGS:
        return
    done = subprocess.run([sys.executable, "-c", _VERIFY], capture_output=True, text=True, timeout=120)
    if done.returncode != 0:
        raise InterfaceBuildError(f"the installed {pkg.name} does not work in rclpy:\n{done.stderr[-3000:]}")


@contextlib.contextmanager
def _lock(layout: _Layout) -> Iterator[None]:
    """One build per virtualenv at a time (make and a test may both ask for it)."""
    key = hashlib.sha256(str(layout.prefix).encode()).hexdigest()[:16]
    with open(Path(tempfile.gettempdir()) / f"nutty-interfaces-{key}.lock", "w") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        yield


def build(
    pkg: InterfacePackage = TF2_MSGS, *, force: bool = False, layout: _Layout | None = None
) -> BuildResult:
    """Generate, compile and install `pkg` into the running virtualenv unless it is already up to date.

    Raises InterfaceBuildError (nothing installed) naming what is missing or which step failed.
    """
    layout = layout or venv_layout()
    start = time.perf_counter()
    if missing := missing_prerequisites(pkg, layout):
        raise InterfaceBuildError(f"cannot build {pkg.name}; missing:\n  " + "\n  ".join(missing))
    digest = inputs_digest(pkg)
    with _lock(layout):
        previous = installed_files(pkg, layout)
        if not force and _installed_digest(pkg, layout) == digest:
            return BuildResult("up to date", time.perf_counter() - start, tuple(previous or ()))
        foreign = layout.site / pkg.name
        if previous is None and foreign.exists():
            raise InterfaceBuildError(f"{foreign} was not installed by this build; not overwriting it")
        with tempfile.TemporaryDirectory(prefix=f"nutty-{pkg.name}-") as tmp:
            build_dir = Path(tmp)
            gen = generate(pkg, layout, build_dir)
            stage = build_dir / "stage"
            staged = _Layout(stage, stage / layout.site.relative_to(layout.prefix))
            with ThreadPoolExecutor(max_workers=max(1, min(4, os.cpu_count() or 1))) as pool:
                for step in _libraries(pkg, staged, gen):
                    list(pool.map(lambda lib: _compile(lib, layout, gen, stage), step))
            _stage_files(pkg, staged, gen, build_dir, stage)
            if previous:
                _remove(previous, layout.prefix)
            written = _install(pkg, layout, stage, digest)
        try:
            _verify(pkg)
        except (InterfaceBuildError, subprocess.TimeoutExpired):
            _remove(written, layout.prefix)
            raise
    return BuildResult("built", time.perf_counter() - start, tuple(written))


def main(argv: Sequence[str] | None = None) -> int:
    """`python -m backend.ros2.interfaces build [--force]`; exit status 0 when tf2_msgs is usable."""
    parser = argparse.ArgumentParser(
        prog="python -m backend.ros2.interfaces", description="Build tf2_msgs into this venv"
    )
    sub = parser.add_subparsers(dest="command", required=True)
    make = sub.add_parser("build", help="generate and compile tf2_msgs into this virtualenv")
    make.add_argument("--force", action="store_true", help="rebuild even when the installed build is current")
    sub.add_parser("check", help="list what the build needs and this machine lacks")
    args = parser.parse_args(argv)
    if args.command == "check":
        missing = missing_prerequisites(TF2_MSGS, venv_layout())
        print("\n".join(missing) if missing else "everything the build needs is here")
        return 1 if missing else 0
    try:
        result = build(force=args.force)
    except InterfaceBuildError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    print(f"{TF2_MSGS.name}: {result.status} in {result.seconds:.1f} s ({len(result.files)} files)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

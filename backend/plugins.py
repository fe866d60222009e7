"""Plugins: the one way blocks, commands, drivers and importers are found.

Each kind is a group of Python entry points. A distribution (this project, or any package installed
beside it) lists one entry per class in its pyproject.toml, named after the class's own declared name:

    [project.entry-points."nutty.blocks"]       # name = Block.type_name
    math = "backend.engine.blocks.signals:Math"
    [project.entry-points."nutty.commands"]     # name = the command's `type`
    play_clip = "backend.control.clips:PlayClip"
    [project.entry-points."nutty.drivers"]      # name = DriverOption.name (its --flag)
    osc = "backend.drivers.osc:OscDriver"
    [project.entry-points."nutty.importers"]    # name = Importer.name
    bvh = "backend.importers.bvh:BvhImporter"

The entries are read from the installed metadata, so after editing them: `pip install -e .`.

Each registry (`backend.engine.blocks.BLOCKS`, `backend.control.REGISTRY`,
`backend.drivers.DRIVER_OPTIONS`, `backend.importers.IMPORTERS`) fills itself from its group with
`load` when its package is imported, and reads it again with its `reload()`. Importing a module
registers nothing: a class is in a registry because an entry point names it.

Order: this project's entries first, then other distributions' by distribution name; within one
distribution by entry name (as setuptools writes them), so every process sees the same order.

An entry that cannot be imported, whose class declares another name, that the registry refuses, or whose
name an earlier entry of the group took, is a PluginError naming the entry point and its distribution.

A plugin package keeps each kind in a module of its own (blocks, commands, ...): a registry loads its
group when its package is first imported, possibly while another one is loading, and a module that is
still being imported cannot hand over its classes yet.
"""

from __future__ import annotations

import importlib.metadata as metadata
import re
from collections.abc import Callable
from typing import Any

HOME = "nutty"  # this project's distribution


class PluginError(RuntimeError):
    """An entry point that cannot be used; the message names it and its distribution."""


def _dist_name(ep: metadata.EntryPoint) -> str:
    dist = getattr(ep, "dist", None)
    return re.sub(r"[-_.]+", "-", dist.name or "").lower() if dist is not None else ""


def describe(ep: metadata.EntryPoint) -> str:
    """`entry point 'name = module:Class' in group 'nutty.x' of distribution 'dist 1.0'`."""
    dist = getattr(ep, "dist", None)
    where = f"distribution '{dist.name} {dist.version}'" if dist is not None else "an unknown distribution"
    return f"entry point '{ep.name} = {ep.value}' in group '{ep.group}' of {where}"


def entries(group: str) -> list[metadata.EntryPoint]:
    """The group's entry points of every installed distribution, in load order (see the module doc)."""
    found = metadata.entry_points(group=group)
    return sorted(found, key=lambda ep: (_dist_name(ep) != HOME, _dist_name(ep), ep.name))


def load(group: str, name_of: Callable[[Any], Any], add: Callable[[Any], object]) -> list[str]:
    """Import every class of `group`, check that `name_of(cls)` is its entry's name and hand it to `add`
    (the registry's own check and insertion: TypeError/ValueError refuse it). The names, in order.

    Raises PluginError for the first entry that fails, naming it; for no entry of this project's own
    distribution at all, saying to install it (its metadata is what lists the bundled classes).
    """
    found = entries(group)
    if not any(_dist_name(ep) == HOME for ep in found):
        raise PluginError(
            f"no '{group}' entry points of the '{HOME}' distribution are installed: the package metadata "
            "is missing or stale; run `pip install -e .` in the repository"
        )
    taken: dict[str, metadata.EntryPoint] = {}
    for ep in found:
        if ep.name in taken:
            raise PluginError(
                f"{describe(ep)} clashes with {describe(taken[ep.name])}: both are named '{ep.name}'"
            )
        try:
            obj = ep.load()
        except Exception as exc:  # whatever a plugin's import raises, the message names the entry
            raise PluginError(f"{describe(ep)} cannot be loaded: {type(exc).__name__}: {exc}") from exc
        try:
            declared = name_of(obj)
        except (AttributeError, KeyError, TypeError) as exc:
            _add(ep, add, obj)  # the registry's refusal says best what the object is not
            raise PluginError(
                f"{describe(ep)}: {ep.value} declares no name ({type(exc).__name__}: {exc})"
            ) from exc
        if declared != ep.name:
            raise PluginError(
                f"{describe(ep)}: {ep.value} declares the name {declared!r}; the entry must be named after it"
            )
        _add(ep, add, obj)
        taken[ep.name] = ep
    return list(taken)


def _add(ep: metadata.EntryPoint, add: Callable[[Any], object], obj: Any) -> None:
    try:
        add(obj)
    except (TypeError, ValueError) as exc:
        raise PluginError(f"{describe(ep)}: {exc}") from exc

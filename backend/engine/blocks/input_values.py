"""The live values of a program's exposed inputs, with a count of their changes.

Commands write them at tick boundaries (`set_input`, `set_inputs`, a program's defaults on a swap);
`input` blocks read them. The compiled core (backend/engine/core/program.py) reads an input block's
value only when `version` moved since it last did, instead of ticking the block every tick: most ticks
no input changed.
"""

from __future__ import annotations

from typing import Any


class InputValues(dict[str, Any]):
    """A dict whose every change adds one to `version`."""

    version: int = 0

    def _changed(self) -> None:
        self.version += 1

    def __setitem__(self, key: str, value: Any) -> None:
        super().__setitem__(key, value)
        self._changed()

    def __delitem__(self, key: str) -> None:
        super().__delitem__(key)
        self._changed()

    def update(self, *args: Any, **kwargs: Any) -> None:
        super().update(*args, **kwargs)
        self._changed()

    def setdefault(self, key: str, default: Any = None) -> Any:
        self._changed()
        return super().setdefault(key, default)

    def pop(self, key: str, *default: Any) -> Any:
        self._changed()
        return super().pop(key, *default)

    def popitem(self) -> tuple[str, Any]:
        self._changed()
        return super().popitem()

    def clear(self) -> None:
        super().clear()
        self._changed()

    def __ior__(self, other: Any) -> InputValues:
        self.update(other)
        return self

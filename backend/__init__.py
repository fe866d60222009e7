"""Nutty: a programmable robot animation engine."""

from importlib import metadata as _metadata


def _version() -> str:
    """The installed distribution's version: pyproject.toml's [project] version is the one source."""
    try:
        return _metadata.version("nutty")
    except _metadata.PackageNotFoundError:  # run from a source tree that was never pip-installed
        return _version_from_pyproject()


def _version_from_pyproject() -> str:
    import tomllib  # only for an uninstalled tree
    from pathlib import Path  # only for an uninstalled tree

    pyproject = Path(__file__).resolve().parents[1] / "pyproject.toml"
    try:
        return str(tomllib.loads(pyproject.read_text())["project"]["version"])
    except (OSError, KeyError, tomllib.TOMLDecodeError):  # not beside its pyproject either
        return "0+unknown"


__version__ = _version()

# Before any compiled kernel is defined: their cache follows the compiled sources (see numba_cache.py).
from backend.numba_cache import configure as _configure_numba_cache  # noqa: E402  (after the version)

_configure_numba_cache()

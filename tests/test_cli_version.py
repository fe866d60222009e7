"""One version: pyproject.toml's [project] version is what `nutty --version`, the API and the Blender
add-on's archive say, and the other places that state a version agree with it."""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import pytest

import backend
from backend.cli import main

ROOT = Path(__file__).resolve().parents[1]
PROJECT_VERSION = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]


def load_build_addon():
    spec = importlib.util.spec_from_file_location("build_addon", ROOT / "blender" / "build_addon.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_package_version_is_pyprojects():
    assert backend.__version__ == PROJECT_VERSION
    assert backend._version_from_pyproject() == PROJECT_VERSION


def test_the_version_without_installed_metadata(monkeypatch):
    from importlib import metadata

    def missing(name):
        raise metadata.PackageNotFoundError(name)

    monkeypatch.setattr(metadata, "version", missing)
    assert backend._version() == PROJECT_VERSION  # read from the source tree's pyproject.toml


def test_nutty_version_prints_it(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["--version"])
    assert exit_.value.code == 0
    assert capsys.readouterr().out.strip() == f"nutty {PROJECT_VERSION}"


def test_nutty_version_from_the_command_line():
    out = subprocess.run(
        [sys.executable, "-m", "backend.cli", "--version"], capture_output=True, text=True, timeout=120
    )
    assert out.returncode == 0 and out.stdout.strip() == f"nutty {PROJECT_VERSION}", out.stderr


def test_the_api_states_the_same_version():
    from backend.api import create_app
    from backend.engine.embodiment import load_embodiment
    from backend.session import EngineSession

    session = EngineSession.create(load_embodiment("nutty_desk"), rate=100)
    try:
        assert create_app(session, frontend_dir=None).version == PROJECT_VERSION
    finally:
        session.engine.close()


def test_the_addon_archive_carries_the_project_version(tmp_path):
    build_addon = load_build_addon()
    target = build_addon.build(tmp_path)
    assert target.name == f"nutty_blender-{PROJECT_VERSION}.zip"
    with zipfile.ZipFile(target) as zf:
        manifest = tomllib.loads(zf.read("blender_manifest.toml").decode())
    assert manifest["version"] == PROJECT_VERSION
    stamped = build_addon.stamped_manifest('schema_version = "1.0.0"\nversion = "9.9.9"\n', "1.2.3")
    assert tomllib.loads(stamped) == {"schema_version": "1.0.0", "version": "1.2.3"}


def test_the_versions_stated_elsewhere_agree():
    """Files that must state a version themselves (Blender reads the source manifest when the add-on
    runs from the tree; npm reads package.json) are kept equal to the project's."""
    manifest = tomllib.loads((ROOT / "blender" / "nutty_blender" / "blender_manifest.toml").read_text())
    assert manifest["version"] == PROJECT_VERSION
    package = ROOT / "frontend" / "package.json"
    if package.exists():
        assert json.loads(package.read_text())["version"] == PROJECT_VERSION

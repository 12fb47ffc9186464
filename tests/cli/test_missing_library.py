"""A machine without open3d's system library (``libusb-1.0.so.0``) gets one error line naming
the package to install, never "internal error ... this is a bug in aion" (issue 16)."""

from __future__ import annotations

import importlib.abc
import sys
from pathlib import Path

import pytest

from tests.cli.conftest import Office, assert_one_line_error, run

AT = "2026-11-23 08:30"
LOADER_ERROR = "libusb-1.0.so.0: cannot open shared object file: No such file or directory"


class _NoLibusb(importlib.abc.MetaPathFinder):
    """Fails ``import open3d`` the way the dynamic loader does on a machine without libusb."""

    def find_spec(self, fullname: str, path: object, target: object = None) -> None:
        if fullname == "open3d" or fullname.startswith("open3d."):
            raise ImportError(LOADER_ERROR)
        return


@pytest.fixture
def without_libusb(monkeypatch: pytest.MonkeyPatch) -> None:
    for name in [n for n in sys.modules if n == "open3d" or n.startswith("open3d.")]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setattr(sys, "meta_path", [_NoLibusb(), *sys.meta_path])


def test_export_without_libusb_names_the_package(
    office: Office, tmp_path: Path, without_libusb: None
) -> None:
    out = tmp_path / "out"
    result = run("export", office.map, "--time", AT, "-o", out)
    assert result.exit_code == 1
    assert_one_line_error(result.stderr, "open3d cannot be loaded", "libusb-1.0.so.0")
    assert "hint: install the system library libusb-1.0" in result.stderr
    assert "libusb-1.0-0" in result.stderr
    assert "bug in aion" not in result.stderr
    assert not out.exists()  # nothing half-written


def test_commands_without_open3d_still_work(office: Office, without_libusb: None) -> None:
    """Only the scene export needs open3d: predict and info run on the same machine."""
    assert run("predict", office.map, "--time", AT).exit_code == 0
    assert run("info", office.map).exit_code == 0


class _NoOpen3d(importlib.abc.MetaPathFinder):
    """A core install: the ``export`` extra (open3d) is not there."""

    def find_spec(self, fullname: str, path: object, target: object = None) -> None:
        if fullname == "open3d" or fullname.startswith("open3d."):
            raise ModuleNotFoundError(f"No module named {fullname!r}", name=fullname)


def test_export_without_the_export_extra_names_the_pip_command(
    office: Office, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    for name in [n for n in sys.modules if n == "open3d" or n.startswith("open3d.")]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setattr(sys, "meta_path", [_NoOpen3d(), *sys.meta_path])
    out = tmp_path / "out"
    result = run("export", office.map, "--time", AT, "-o", out)
    assert result.exit_code == 1
    assert_one_line_error(result.stderr, "PLY/PCD scenes need open3d")
    assert "hint: pip install 'aion[export]'" in result.stderr
    assert not out.exists()

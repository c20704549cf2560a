"""The app reads and writes only .toml files inside rigs/ and the chosen work folder."""

from __future__ import annotations

import os

import pytest

from rigsim.errors import ConfigError
from rigsim.ui.files import FileSandbox


@pytest.fixture
def box(tmp_path):
    rigs, work = tmp_path / "rigs", tmp_path / "work"
    rigs.mkdir()
    work.mkdir()
    (rigs / "a.toml").write_text("[rig]\n")
    return FileSandbox({"rigs": rigs, "work": work})


@pytest.mark.parametrize("name", ["../../etc/x.toml", "/tmp/x.toml", "../x.toml", "/etc/passwd", "~/x.toml",
                                  "sub/../../x.toml", "", "   ", "a\x00b.toml", "x.txt", "x.py", "."])
def test_refused(box, name):
    with pytest.raises(ConfigError) as e:
        box.write_text(name, "x", folder="work")
    assert "\n" not in str(e.value)
    with pytest.raises(ConfigError):
        box.read_text(name, folder="rigs")


def test_symlink_out_is_refused(box, tmp_path):
    outside = tmp_path / "outside"
    outside.mkdir()
    os.symlink(outside, box.folders["work"] / "link")
    with pytest.raises(ConfigError, match="outside"):
        box.write_text("link/x.toml", "x", folder="work")
    assert not (outside / "x.toml").exists()


def test_inside_is_allowed_and_overwrite_is_explicit(box, tmp_path):
    p = box.write_text("mine.toml", "[rig]\n", folder="work")
    assert p == (tmp_path / "work" / "mine.toml").resolve() and p.read_text() == "[rig]\n"
    with pytest.raises(ConfigError, match="exists"):
        box.write_text("mine.toml", "y", folder="work")
    box.write_text(str(p), "[camera]\n", folder="rigs", overwrite=True)  # absolute, inside: fine
    assert box.read_text("mine.toml", folder="work")[1] == "[camera]\n"
    assert [f["name"] for f in box.list_files()] == ["a.toml", "mine.toml"]
    with pytest.raises(ConfigError, match="unknown folder"):
        box.resolve("a.toml", folder="elsewhere")

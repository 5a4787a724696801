"""Atomic writes: complete content, the old file kept on failure, no temporary files left."""

import os

import pytest
from matplotlib.figure import Figure

from aquafish_gym.files import atomic_write, save_figure


def test_atomic_write_writes_and_replaces(tmp_path):
    path = tmp_path / "a.json"
    atomic_write(path, b"first")
    assert path.read_bytes() == b"first"
    atomic_write(path, b"second, longer content")
    assert path.read_bytes() == b"second, longer content"
    assert os.listdir(tmp_path) == ["a.json"]


def test_atomic_write_gives_the_permissions_of_a_plain_open(tmp_path):
    plain, atomic = tmp_path / "plain", tmp_path / "atomic"
    plain.write_bytes(b"x")
    atomic_write(atomic, b"x")
    assert atomic.stat().st_mode == plain.stat().st_mode


def test_failed_rename_keeps_the_old_file_and_removes_the_temporary(tmp_path, monkeypatch):
    path = tmp_path / "a.json"
    path.write_bytes(b"old")

    def fail(src, dst):
        raise OSError("disk on fire")

    monkeypatch.setattr(os, "replace", fail)
    with pytest.raises(OSError, match="disk on fire"):
        atomic_write(path, b"new")
    assert path.read_bytes() == b"old"
    assert os.listdir(tmp_path) == ["a.json"]


def test_failed_write_keeps_the_old_file_and_removes_the_temporary(tmp_path):
    path = tmp_path / "a.txt"
    path.write_bytes(b"old")
    with pytest.raises(TypeError):
        atomic_write(path, "text, not bytes")  # the write itself fails
    assert path.read_bytes() == b"old"
    assert os.listdir(tmp_path) == ["a.txt"]


def test_missing_directory_raises(tmp_path):
    with pytest.raises(FileNotFoundError):
        atomic_write(tmp_path / "nope" / "a.txt", b"x")


def test_save_figure_writes_a_png_and_creates_parents(tmp_path):
    fig = Figure(figsize=(2, 2))
    fig.add_subplot().plot([0, 1], [1, 0])
    path = save_figure(fig, tmp_path / "sub" / "f.png", dpi=50)
    assert path == tmp_path / "sub" / "f.png"
    assert path.read_bytes().startswith(b"\x89PNG\r\n\x1a\n")
    assert os.listdir(tmp_path / "sub") == ["f.png"]
    assert save_figure(fig, tmp_path / "f.svg").read_bytes().lstrip().startswith(b"<?xml")


def test_save_figure_without_a_format_raises(tmp_path):
    with pytest.raises(ValueError, match="suffix"):
        save_figure(Figure(), tmp_path / "figure")
    assert os.listdir(tmp_path) == []

"""Tests of sklearn_ifog._io: outputs of one or several files are all or nothing."""

import os

import pytest

from sklearn_ifog import _io


def _snapshot(directory):
    return {path.name: path.read_bytes() for path in sorted(directory.iterdir()) if path.is_file()}


def _write_in_staging(out, files, error=None):
    """Write ``files`` ({name: text}) through staged_directory(out), raising ``error`` last."""
    with _io.staged_directory(out) as staging:
        for name, text in files.items():
            (staging / name).write_text(text)
        if error is not None:
            raise error


def _replace_failing_on(call_number):
    """os.replace, raising OSError on its ``call_number``-th call (1-based)."""
    real, calls = os.replace, []

    def replace(source, target):
        calls.append((source, target))
        if len(calls) == call_number:
            raise OSError("rename failed")
        return real(source, target)

    return replace


def test_staged_directory_makes_a_new_directory_in_one_rename(tmp_path):
    out = tmp_path / "out"
    with _io.staged_directory(out) as staging:
        (staging / "a.txt").write_text("a")
        (staging / "sub").mkdir()
        (staging / "sub" / "b.txt").write_text("b")
        assert not out.exists()
    assert _snapshot(out)["a.txt"] == b"a"
    assert (out / "sub" / "b.txt").read_text() == "b"
    assert os.listdir(tmp_path) == ["out"]
    assert (out.stat().st_mode & 0o777) == (0o777 & ~_io._UMASK)


def test_staged_directory_failing_in_the_block_changes_nothing(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "a.txt").write_text("old a")
    with pytest.raises(RuntimeError):
        _write_in_staging(out, {"a.txt": "new a"}, RuntimeError("half-way"))
    assert _snapshot(out) == {"a.txt": b"old a"}
    assert os.listdir(tmp_path) == ["out"]
    with pytest.raises(RuntimeError):
        _write_in_staging(tmp_path / "new", {"a.txt": "new a"}, RuntimeError("half-way"))
    assert os.listdir(tmp_path) == ["out"]


def test_staged_directory_into_an_existing_one_replaces_and_keeps(tmp_path):
    out = tmp_path / "out"
    (out / "sub").mkdir(parents=True)
    (out / "sub" / "old.txt").write_text("old")
    (out / "a.txt").write_text("old a")
    (out / "mine.txt").write_text("kept")
    with _io.staged_directory(out) as staging:
        (staging / "a.txt").write_text("new a")
        (staging / "sub").mkdir()
        (staging / "sub" / "new.txt").write_text("new")
    assert _snapshot(out)["a.txt"] == b"new a"
    assert _snapshot(out)["mine.txt"] == b"kept"
    assert os.listdir(out / "sub") == ["new.txt"]  # a directory is replaced as a whole
    assert os.listdir(tmp_path) == ["out"]


def test_staged_directory_undoes_the_renames_when_one_fails(tmp_path, monkeypatch):
    out = tmp_path / "out"
    out.mkdir()
    for name in ("a.txt", "b.txt", "c.txt"):
        (out / name).write_text(f"old {name}")
    before = _snapshot(out)
    # calls: a aside, a in, b aside, b in (fails)
    monkeypatch.setattr(_io.os, "replace", _replace_failing_on(4))
    with pytest.raises(OSError, match="rename failed"):
        _write_in_staging(out, {name: f"new {name}" for name in ("a.txt", "b.txt", "new.txt")})
    monkeypatch.undo()
    assert _snapshot(out) == before
    assert os.listdir(tmp_path) == ["out"]


def test_write_text_files_undoes_the_renames_when_one_fails(tmp_path, monkeypatch):
    header, source = tmp_path / "ifog.h", tmp_path / "ifog.c"
    header.write_text("old header")
    before = _snapshot(tmp_path)
    # calls: header aside, header in, source in (fails; source is new)
    monkeypatch.setattr(_io.os, "replace", _replace_failing_on(3))
    with pytest.raises(OSError, match="rename failed"):
        _io.write_text_files({header: "new header", source: "new source"})
    monkeypatch.undo()
    assert _snapshot(tmp_path) == before


def test_staged_directory_refuses_a_missing_parent_or_a_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="does not exist"):
        _write_in_staging(tmp_path / "no" / "out", {})
    (tmp_path / "file").write_text("")
    with pytest.raises(NotADirectoryError, match="not a directory"):
        _write_in_staging(tmp_path / "file", {})

"""Atomic file writing: a failure never leaves a half-written output behind.

Every file the package writes (models, reports, figures, CSVs, exported C and JSON, benchmark
tables) goes through here: it is written to a temporary sibling and renamed over the target
only once complete. Outputs of several files are all-or-nothing:

- :func:`atomic_path`: one file, one rename.
- :func:`write_text_files`: several text files, each written to a temporary sibling; only
  when all are written are they renamed into place, and if a rename fails the ones already
  done are undone (the old files are put back, new ones removed).
- :func:`staged_directory`: a directory of outputs, written into a hidden sibling staging
  directory. A directory that did not exist appears in one rename, complete. Into an existing
  directory, each staged entry then replaces its namesake, with the same undo on failure;
  entries of the directory that are not rewritten are kept.

What is guaranteed: an exception while writing (in the ``with`` block, or in
:func:`write_text_files`) changes nothing at the targets, and an exception during the final
renames is undone. Only a crash of the machine (power loss) in the middle of those renames,
which take microseconds, can leave some targets new and some old; and while an existing
entry is being replaced it is briefly absent (it is moved aside, then the new one moved in).
"""

import contextlib
import os
import shutil
import tempfile
import uuid
from pathlib import Path

# Read once: mkstemp creates files with mode 0600, and an output should get the same
# permissions as any other file the user writes.
_UMASK = os.umask(0)
os.umask(_UMASK)


@contextlib.contextmanager
def atomic_path(path):
    """Yield a temporary path next to ``path``; rename it to ``path`` only on success.

    On any exception the temporary file is removed and ``path`` is left untouched.

    Parameters
    ----------
    path : str or path-like
        The file to write.

    Yields
    ------
    temporary : pathlib.Path
        Where to write; it becomes ``path`` when the block ends without an exception.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> with tempfile.TemporaryDirectory() as directory:
    ...     target = Path(directory) / "out.txt"
    ...     with atomic_path(target) as temporary:
    ...         _ = temporary.write_text("done")
    ...     print(target.read_text())
    done
    """
    path = Path(path)
    descriptor, temporary = tempfile.mkstemp(
        dir=path.parent, prefix=f".{path.name}.", suffix=".tmp"
    )
    os.close(descriptor)
    temporary = Path(temporary)
    try:
        yield temporary
        os.chmod(temporary, 0o666 & ~_UMASK)
        os.replace(temporary, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            temporary.unlink()
        raise


def _remove(path):
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path)
    else:
        path.unlink()


def _replace_all(moves):
    """Rename every ``(source, target)`` pair over its target, all or none.

    Existing targets are first moved aside (to a hidden sibling), so that directories can be
    replaced too; if any rename fails, the new entries already moved in are removed and the
    old ones put back before the exception propagates. The old entries are deleted once all
    renames succeeded.
    """
    done = []  # (target, its old entry moved aside, or None)
    try:
        for source, target in moves:
            source, target = Path(source), Path(target)
            aside = None
            if target.exists() or target.is_symlink():
                aside = target.with_name(f".{target.name}.{uuid.uuid4().hex}.old")
                os.replace(target, aside)
            done.append((target, aside))
            os.replace(source, target)
    except BaseException:
        for target, aside in reversed(done):
            if target.exists() or target.is_symlink():  # the new entry, moved in
                _remove(target)
            if aside is not None:
                os.replace(aside, target)
        raise
    for _, aside in done:
        if aside is not None:
            with contextlib.suppress(FileNotFoundError):
                _remove(aside)


def write_text_files(files):
    """Write several text files so that either all of them appear, or none changes.

    Every file is first written to a temporary sibling; the renames happen only once all are
    written, and are undone if one of them fails (see the module notes for the exact
    guarantee).

    Parameters
    ----------
    files : dict of path-like to str
        ``{path: text}``; text is written as UTF-8 with ``\\n`` line endings.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> with tempfile.TemporaryDirectory() as directory:
    ...     a, b = Path(directory) / "a.h", Path(directory) / "a.c"
    ...     write_text_files({a: "header", b: "source"})
    ...     print(a.read_text(), b.read_text())
    header source
    """
    staged = []
    try:
        for path, text in files.items():
            path = Path(path)
            handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.")
            staged.append((temporary, path))
            with os.fdopen(handle, "w", encoding="utf-8", newline="\n") as stream:
                stream.write(text)
            os.chmod(temporary, 0o666 & ~_UMASK)
        _replace_all(staged)
    finally:
        for temporary, _ in staged:
            if os.path.exists(temporary):
                os.remove(temporary)


@contextlib.contextmanager
def staged_directory(out):
    """Yield a fresh staging directory; on success its entries become those of ``out``.

    A hidden staging directory is made next to ``out``. When the block ends without an
    exception: if ``out`` does not exist, the staging directory is renamed to ``out`` (one
    rename: the directory appears complete); otherwise each staged entry replaces its
    namesake in ``out`` (undone if a rename fails), and entries of ``out`` that were not
    staged are kept. On an exception in the block, the staging directory is removed and
    ``out`` is untouched.

    Parameters
    ----------
    out : str or path-like
        The output directory; its parent must exist.

    Yields
    ------
    staging : pathlib.Path
        The directory to write into.

    Raises
    ------
    FileNotFoundError
        If the parent of ``out`` does not exist.
    NotADirectoryError
        If ``out`` exists and is not a directory.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> with tempfile.TemporaryDirectory() as directory:
    ...     out = Path(directory) / "results"
    ...     with staged_directory(out) as staging:
    ...         _ = (staging / "a.txt").write_text("a")
    ...         _ = (staging / "b.txt").write_text("b")
    ...         print(out.exists())
    ...     print(sorted(path.name for path in out.iterdir()))
    False
    ['a.txt', 'b.txt']
    """
    out = Path(out)
    parent = out.parent
    if not parent.is_dir():
        raise FileNotFoundError(f"{out}: the directory {parent} does not exist")
    if out.exists() and not out.is_dir():
        raise NotADirectoryError(f"{out} exists and is not a directory")
    staging = Path(tempfile.mkdtemp(dir=parent, prefix=f".{out.name}.", suffix=".tmp"))
    try:
        yield staging
        if not out.exists():
            os.chmod(staging, 0o777 & ~_UMASK)
            os.rename(staging, out)
        else:
            _replace_all([(item, out / item.name) for item in sorted(staging.iterdir())])
    finally:
        shutil.rmtree(staging, ignore_errors=True)

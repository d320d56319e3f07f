"""Atomic file writing: a failure never leaves a half-written output behind.

Every file the package writes (models, reports, figures, CSVs, exported C and JSON, benchmark
tables) goes through here: it is written to a temporary sibling and renamed over the target
only once complete.
"""

import contextlib
import os
import tempfile
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


def write_text_files(files):
    """Write several text files so that either all of them appear, or none changes.

    Every file is first written to a temporary sibling; the renames happen only once all are
    written.

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
        for temporary, path in staged:
            os.replace(temporary, path)
    finally:
        for temporary, _ in staged:
            if os.path.exists(temporary):
                os.remove(temporary)

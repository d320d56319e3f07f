"""A step-by-step progress display on stderr, with no dependency."""

import contextlib
import sys
import threading
import time


class Progress:
    """Step-by-step progress on stderr, with no dependency.

    Each step prints ``[i/n] label`` when it starts and its duration when it ends. On a
    terminal a background thread redraws the line every quarter second with the elapsed
    time (and a bar when the step has a known number of items), so a step that takes more
    than a second is visibly alive; in a log (not a terminal) only the start and end lines
    appear.
    """

    def __init__(self, n_steps, stream=None, enabled=True):
        self.n_steps = n_steps
        self.stream = sys.stderr if stream is None else stream
        self.enabled = enabled
        self.live = enabled and hasattr(self.stream, "isatty") and self.stream.isatty()
        self._index = 0

    def _write(self, text):
        self.stream.write(text)
        self.stream.flush()

    @contextlib.contextmanager
    def step(self, label, total=None):
        """Context manager for one step; yields ``advance(n=1)`` to move the bar."""
        self._index += 1
        prefix = f"[{self._index}/{self.n_steps}] {label}"
        state = {"done": 0}
        lock = threading.Lock()
        start = time.perf_counter()

        def line():
            elapsed = time.perf_counter() - start
            if total:
                filled = int(20 * state["done"] / total)
                bar = "#" * filled + "-" * (20 - filled)
                return f"{prefix} [{bar}] {state['done']}/{total} {elapsed:5.1f} s"
            return f"{prefix} ... {elapsed:5.1f} s"

        def advance(n=1):
            with lock:
                state["done"] += n
                if self.enabled and not self.live:
                    self._write(f"    {prefix}: {state['done']}/{total}\n")

        stop = threading.Event()
        ticker = None
        if self.live:

            def redraw():
                while not stop.wait(0.25):
                    with lock:
                        self._write("\r" + line() + "\x1b[K")

            ticker = threading.Thread(target=redraw, daemon=True)
            self._write(line())
            ticker.start()
        elif self.enabled:
            self._write(prefix + " ...\n")
        outcome = "failed after"
        try:
            yield advance
            outcome = "done in"
        finally:
            stop.set()
            if ticker is not None:
                ticker.join()
            if self.enabled:
                elapsed = time.perf_counter() - start
                ending = f"{prefix}: {outcome} {elapsed:.1f} s"
                self._write(("\r" + ending + "\x1b[K\n") if self.live else f"    {ending}\n")

"""How a command-line process spends its start and its exit (`skelcore run` and the bench's timed children).

Python's cyclic garbage collector is the wrong tool for both ends of a short process:
- while the modules load (numpy, scipy, networkx, CHOLMOD, ...) they create some 60,000 objects that live as
  long as the process; the collector, run every 700 allocations, traverses them about 150 times and frees
  nothing: 0.06-0.1 s of CPU of a 10k-point run's start-up;
- at exit it traverses every object once more before the process ends and the operating system takes the
  memory back anyway: 0.1 s.
`begin` turns the collector off for the imports and skips that last collection; `loaded` moves what the
imports made out of its sight (gc.freeze) and turns it back on, so the run itself is collected as usual.
"""
from __future__ import annotations

import atexit
import gc


def begin() -> None:
    """At the start of a command-line process: no collection while the modules load, none at exit."""
    gc.disable()
    atexit.register(gc.freeze)  # atexit runs before the interpreter's final collection, which then skips all


def loaded() -> None:
    """Once the modules are loaded: the objects they made leave the collector's generations; it runs again."""
    if not gc.isenabled():
        gc.freeze()
        gc.enable()

"""Wall-clock timing of JAX calls: the library's own (``jaxcontact demo`` and
``jaxcontact bench --quick`` time with it), so the benchmarks and the command
line measure alike."""

from benchmarks.harness.internals import (
    Timing,
    _elapsed,
    compiled_call,
    pinned_note,
    time_call,
    time_interleaved,
)

__all__ = ["Timing", "_elapsed", "compiled_call", "pinned_note", "time_call", "time_interleaved"]

"""Ctrl-C that always lands: the command line's SIGINT handler and the checks that make it reliable.

Paper: none; the rule is the project's (an interrupted run ends with one line and exit status
130, and the previous outputs stay untouched). Python's own handler raises KeyboardInterrupt
wherever the main thread happens to be; inside a ctypes callback (llvmlite calls back into
Python while numba compiles a kernel or loads it from its cache) that exception is printed as
"ignored" and lost, and the run goes on. So:

* :func:`install` (called by the command line before its heavy imports) puts a handler in place
  that records the interrupt (:func:`pending`) and raises KeyboardInterrupt, as Python's does,
  except while numba's compiler lock is held (:func:`defer_during_numba`): there it only records
  it, and the interrupt is raised when the lock is released, after the kernel was compiled or
  loaded -- outside any callback.
* :func:`check` raises KeyboardInterrupt when an interrupt was recorded but may have been
  swallowed; the atomic output folders call it just before they put new outputs in place, and
  the command line before it reports success.

Library code that never calls :func:`install` is unaffected: nothing is recorded, :func:`check`
does nothing.
"""

from __future__ import annotations

import signal
import threading

__all__ = ["install", "uninstall", "pending", "check", "reset", "defer_during_numba", "quiet", "settle",
           "record_outcome", "outcome"]

_state = {"pending": False, "depth": 0, "quiet": False, "installed": None, "listener": None, "outcome": None}


def record_outcome(text: str) -> None:
    """What the outputs are now (``"the new outputs were complete and are in OUT"``): said by the
    interrupted line of a Ctrl-C that lands after it, outside the block that wrote them."""
    _state["outcome"] = text


def outcome() -> str:
    """The last recorded outcome, or that no outputs were written."""
    return _state["outcome"] or "no outputs were written"


#: Functions Python calls where an exception cannot propagate (it is printed as "ignored" and lost):
#: finalizers and the weak-reference callbacks of the import system.
_NO_RAISE = frozenset({"__del__", "cb", "_remove", "_release_save"})


def _handler(signum, frame) -> None:
    _state["pending"] = True
    if _state["depth"] > 0 or _state["quiet"]:
        return  # inside numba's compiler (or while reporting): raised when it ends (see _Deferrer)
    if frame is not None and frame.f_code.co_name in _NO_RAISE:
        _redeliver()  # raising here would be swallowed: signal again in a moment, outside the callback
        return
    raise KeyboardInterrupt


def _redeliver(delay: float = 0.02) -> None:
    main = threading.main_thread().ident
    t = threading.Timer(delay, lambda: signal.pthread_kill(main, signal.SIGINT))
    t.daemon = True
    t.start()


def install() -> bool:
    """Install the handler (main thread only, and only over Python's default one); True when installed."""
    if threading.current_thread() is not threading.main_thread():
        return False
    if signal.getsignal(signal.SIGINT) is not signal.default_int_handler and _state["installed"] is None:
        return False  # someone else's handler (a test runner, an embedding application): leave it
    _state["installed"] = signal.signal(signal.SIGINT, _handler) if _state["installed"] is None else _state["installed"]
    return True


def uninstall() -> None:
    """Put back the handler :func:`install` replaced."""
    if _state["installed"] is not None:
        signal.signal(signal.SIGINT, _state["installed"])
        _state["installed"] = None


def pending() -> bool:
    """True when an interrupt arrived since the last :func:`reset`."""
    return bool(_state["pending"])


def reset() -> None:
    """Forget a recorded interrupt and outcome (at the start of a command run in-process)."""
    _state["pending"] = False
    _state["quiet"] = False
    _state["outcome"] = None


def check() -> None:
    """Raise KeyboardInterrupt when an interrupt was recorded (it may have been swallowed on its way)."""
    if _state["pending"]:
        raise KeyboardInterrupt


def settle() -> None:
    """The program is ending: from now on a Ctrl-C is only recorded, then (for the interpreter's
    teardown, when Python puts back the default action and a signal would kill the process) ignored.
    Call :func:`pending` after it to know whether one came."""
    _state["quiet"] = True
    if _state["installed"] is not None and threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)


class quiet:
    """A block in which a further Ctrl-C is only recorded (while the one line is printed)."""

    def __enter__(self) -> None:
        _state["quiet"] = True

    def __exit__(self, *exc) -> None:
        _state["quiet"] = False


def defer_during_numba() -> bool:
    """Record, not raise, interrupts while numba's compiler lock is held; raise them when it is
    released (once per process; False when numba cannot be imported)."""
    if _state["listener"] is not None:
        return True
    try:
        from numba.core import event
    except ImportError:  # pragma: no cover - numba is a core dependency
        return False

    class _Deferrer(event.Listener):
        def on_start(self, ev) -> None:
            if threading.current_thread() is threading.main_thread():
                _state["depth"] += 1

        def on_end(self, ev) -> None:
            if threading.current_thread() is not threading.main_thread():
                return
            _state["depth"] = max(_state["depth"] - 1, 0)
            if _state["depth"] == 0 and _state["pending"] and _state["installed"] is not None and not _state["quiet"]:
                raise KeyboardInterrupt  # the lock is released; the kernel was compiled or loaded whole

    _state["listener"] = _Deferrer()
    event.register("numba:compiler_lock", _state["listener"])
    return True

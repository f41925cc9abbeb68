"""gymtrack.interrupts: a Ctrl-C inside numba's compiler is held back and raised once the kernel is
compiled whole; one inside a finalizer is delivered again outside it; check() raises a recorded one.

The end-to-end behaviour (one line, exit 130, outputs untouched, at three moments of a real run)
is tests/test_cli_outputs.py::test_ctrl_c_one_line_exit_130_nothing_half_written.
"""

from __future__ import annotations

import os
import signal
import time

import numba
import pytest
from numba.core import event

from gymtrack import interrupts


@pytest.fixture
def handler():
    if signal.getsignal(signal.SIGINT) is not signal.default_int_handler and interrupts._state["installed"] is None:
        pytest.skip("another SIGINT handler is installed")
    assert interrupts.install()
    interrupts.reset()
    yield
    interrupts.uninstall()
    interrupts.reset()


class _SignalOnLock(event.Listener):
    """Sends SIGINT to this process the first time numba takes its compiler lock."""

    def __init__(self) -> None:
        self.sent = False

    def on_start(self, ev) -> None:
        if not self.sent:
            self.sent = True
            os.kill(os.getpid(), signal.SIGINT)

    def on_end(self, ev) -> None:
        pass


def test_ctrl_c_during_a_compile_lands_after_it(handler):
    assert interrupts.defer_during_numba()

    @numba.njit(cache=False)
    def kernel(x):
        s = 0.0
        for i in range(x.shape[0]):
            s += x[i] * i
        return s

    import numpy as np

    sender = _SignalOnLock()
    event.register("numba:compiler_lock", sender)
    try:
        with pytest.raises(KeyboardInterrupt):
            kernel(np.arange(4.0))
    finally:
        event.unregister("numba:compiler_lock", sender)
    assert sender.sent and interrupts.pending()
    assert kernel.signatures  # compiled whole before the interrupt was raised
    assert kernel(np.arange(4.0)) == 14.0


def test_ctrl_c_in_a_finalizer_is_delivered_again_outside_it(handler):
    class Finalised:
        def __del__(self):
            os.kill(os.getpid(), signal.SIGINT)
            for _ in range(1000):  # the handler runs here, in __del__: it must not raise (it would be lost)
                pass

    with pytest.raises(KeyboardInterrupt):
        Finalised()  # dropped at once: __del__ runs
        deadline = time.monotonic() + 5
        while time.monotonic() < deadline:
            time.sleep(0.005)
    assert interrupts.pending()


def test_check_raises_a_recorded_interrupt(handler):
    interrupts.check()  # nothing recorded: nothing happens
    with interrupts.quiet():
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.01)  # recorded, not raised
    assert interrupts.pending()
    with pytest.raises(KeyboardInterrupt):
        interrupts.check()

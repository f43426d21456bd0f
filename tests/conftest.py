import os
import signal

import numpy as np
import pytest

os.environ.setdefault("MPLBACKEND", "Agg")

# A shell without job control starts background jobs (``cmd &``, nohup) with SIGINT ignored, and
# Python keeps it ignored: the tests that deliver a real Ctrl-C (signal.raise_signal) would then see
# nothing and fail for a reason that has nothing to do with the code.  Give the test process the
# handler of an ordinary Python process, the state those tests are about.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)


def pytest_terminal_summary(terminalreporter):
    """One visible line when the browser tests were skipped for a missing browser (outside CI)."""
    import sys

    mod = sys.modules.get("_browser")
    if mod is not None and mod.MISSING:
        terminalreporter.write_line(
            f"browser tests skipped ({mod.MISSING[0]}; CI unset): to run them: {mod.HOW}; with CI=true they fail",
            yellow=True)


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


def random_polydisperse(rng, n, ratio, box, phi_target=0.2):
    """Random (possibly overlapping) polydisperse spheres with size ratio ``ratio``."""
    r = np.exp(rng.uniform(0.0, np.log(ratio), n))
    r = r / r.max()
    vol = 4 / 3 * np.pi * np.sum(r**3)
    scale = (phi_target * box**3 / vol) ** (1 / 3)
    r = r * scale
    r = np.minimum(r, box / 4.0 - 1e-9)
    return rng.random((n, 3)) * box, r

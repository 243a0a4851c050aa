"""Fixtures shared by several test modules."""

import numba
import pytest


@pytest.fixture(scope="module")
def one_numba_thread():
    """For modules of small models (a few to a few dozen elements): numba's thread start-up would dominate the
    element kernel (20 ms against 0.3 ms per call on a loaded 2-core machine), so the kernels run on one thread.
    A module asks for it with ``pytestmark = pytest.mark.usefixtures("one_numba_thread")``."""
    n = numba.get_num_threads()
    numba.set_num_threads(1)
    yield
    numba.set_num_threads(n)


@pytest.fixture
def small_disk(tmp_path):
    """A 300 KiB tmpfs mounted for the test (skipped where mounting is not permitted)."""
    from tests.outputs.common import mount_small_disk, unmount
    path = tmp_path / "disk"
    mount_small_disk(path)
    yield path
    unmount(path)


@pytest.fixture
def terminal_stderr(monkeypatch):
    """``flexbody run`` prints its step lines only when stderr is a terminal: tests that read them from the
    captured (not a terminal) stderr pretend it is one."""
    import flexbody.cli.progress
    monkeypatch.setattr(flexbody.cli.progress, "stderr_is_terminal", lambda: True)

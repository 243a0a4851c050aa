"""Element loops run in chunks from Python (flexbody.chunks): the ranges, the threads, the per-thread scratch,
and that the element kernels give the same bits on one and on two threads."""

from __future__ import annotations

import pickle
import threading

import numba
import numpy as np
import pytest

from flexbody import chunks


@pytest.fixture
def threads():
    """Set numba's thread count for a test (skipped above what numba was started with)."""
    before = numba.get_num_threads()

    def use(n: int) -> None:
        if n > numba.config.NUMBA_NUM_THREADS:
            pytest.skip(f"numba was started with {numba.config.NUMBA_NUM_THREADS} thread(s)")
        numba.set_num_threads(n)

    yield use
    numba.set_num_threads(before)


def test_one_thread_or_a_small_batch_is_one_chunk(threads):
    threads(1)
    assert chunks.n_chunks(10_000) == 1
    threads(2)
    assert chunks.n_chunks(chunks.MIN_PARALLEL - 1) == 1
    assert chunks.n_chunks(10_000) == 8 and chunks.n_chunks(200, min_parallel=16) == 8


@pytest.mark.parametrize("m, n", [(0, 1), (7, 1), (7, 3), (1000, 8), (5, 5)])
def test_the_chunks_cover_every_element_once(threads, m, n):
    threads(2 if n > 1 else 1)
    seen = []
    lock = threading.Lock()

    def run(e0, e1):
        with lock:
            seen.extend(range(e0, e1))

    chunks.run_chunks(run, m, n)
    assert sorted(seen) == list(range(m))


def test_an_exception_in_a_chunk_reaches_the_caller(threads):
    threads(2)

    def run(e0, e1):
        if e0 > 0:
            raise FloatingPointError(f"chunk {e0}")

    with pytest.raises(FloatingPointError, match="chunk"):
        chunks.run_chunks(run, 100, 4)


def test_workspaces_are_made_once_per_thread_and_key_and_pickle_empty():
    made = []

    def make():
        made.append(threading.get_ident())
        return (np.empty(3),)

    ws = chunks.Workspaces()
    first = ws.get(("test", 1), make)
    assert ws.get(("test", 1), make) is first and len(made) == 1
    assert ws.get(("test", 2), make) is not first
    other = []
    worker = threading.Thread(target=lambda: other.append(ws.get(("test", 1), make)))
    worker.start()
    worker.join()
    assert other[0] is not first and len(made) == 3
    assert chunks.Workspaces().get(("test", 1), make) is not first        # another owner, other arrays
    copy = pickle.loads(pickle.dumps(ws))
    assert copy.get(("test", 1), make) is not first and len(made) == 5


def test_a_variant_owns_its_workspaces_and_pickles():
    from flexbody.shell.variants import MITC6
    v = MITC6()
    assert v.workspaces is v.workspaces and MITC6().workspaces is not v.workspaces
    assert pickle.loads(pickle.dumps(v)) == v


def _elements(m: int, seed: int = 0):
    """m randomly moved and deformed copies of a curved element (a cylinder patch of radius 2)."""
    from flexbody.frames import frames_from_directors
    from flexbody.lie import so3
    from flexbody.shell.geometry import element_geometry

    uv = np.array([[0, 0], [1, 0], [0, 1], [0.5, 0], [0.5, 0.5], [0, 0.5]], float) * 0.8 + [0.1, 0.2]
    X = np.array([[2.0 * np.sin(u / 2.0), v, 2.0 * np.cos(u / 2.0)] for u, v in uv])
    frames = frames_from_directors(X * [1.0, 0.0, 1.0] / 2.0, np.array([0.0, 1.0, 0.0]))
    geom = element_geometry(X, frames)
    rng = np.random.default_rng(seed)
    x, fr = np.empty((m, 6, 3)), np.empty((m, 6, 3, 3))
    for e in range(m):
        Rg = so3.exp(1.5 * rng.normal(size=3))
        x[e] = (X + 0.05 * rng.normal(size=X.shape)) @ Rg.T
        fr[e] = [Rg @ frames[i] @ so3.exp(0.3 * rng.normal(size=3)) for i in range(6)]
    return x, fr, np.tile(geom.e_ref, (m, 1, 1)), np.tile(geom.to_cart, (m, 1, 1, 1)), np.tile(geom.weights, (m, 1))


def test_element_kernels_give_the_same_bits_on_one_and_two_threads(threads):
    from flexbody.shell.kernels.loops import internal_force_tangent_batch, linearized_strains_batch
    from flexbody.shell.material import ShellMaterial
    from flexbody.shell.variants import MITC6

    threads(2)
    C = ShellMaterial(young=1.0e3, poisson=0.3, thickness=0.1).section()
    A = MITC6().maps
    args = _elements(3 * chunks.MIN_PARALLEL)
    dh = np.random.default_rng(1).normal(size=(len(args[0]), 36))
    results = []
    for n in (1, 2):
        numba.set_num_threads(n)
        assert chunks.n_chunks(len(args[0])) == (1 if n == 1 else 8)
        results.append((*internal_force_tangent_batch(*args, C, A), *linearized_strains_batch(*args[:4], A, dh)))
    for one, two in zip(*results):
        np.testing.assert_array_equal(one, two)

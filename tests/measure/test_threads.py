"""The measurement's thread pool (voxelmocap.measure.threads): the same results, in order, as a
plain loop, whatever OpenCV's thread count; work handed out from a worker stays in it."""

import threading

import numpy as np
import pytest

from voxelmocap.measure import threads
from voxelmocap.measure.plate import masked_median


def test_width_is_opencvs_thread_count(opencv_threads):
    opencv_threads(1)
    assert threads.width() == 1
    opencv_threads(2)
    assert threads.width() == 2


def test_results_come_in_order_and_equal_a_loop(opencv_threads):
    opencv_threads(2)
    items = list(range(23))
    assert threads.each(lambda x: x * x - 3, items) == [x * x - 3 for x in items]
    assert threads.each(lambda x: x, []) == []


def test_the_first_failing_item_in_order_is_raised(opencv_threads):
    opencv_threads(2)

    def fn(x):
        if x in (3, 5):
            raise ValueError(f"item {x}")
        return x

    with pytest.raises(ValueError, match="item 3"):
        threads.each(fn, range(8))


def test_work_handed_out_from_a_worker_runs_in_that_worker(opencv_threads):
    """A pool of two whose two workers each hand out more work would wait on itself forever;
    nested calls run in the calling worker instead."""
    opencv_threads(2)
    main = threading.current_thread()

    def outer(x):
        here = threading.current_thread()
        inner = threads.each(lambda y: (threading.current_thread(), y), range(4))
        return here, inner

    out = threads.each(outer, range(4))
    assert any(here is not main for here, _ in out)      # the outer calls went to the pool
    for here, inner in out:
        assert [y for _, y in inner] == [0, 1, 2, 3]
        assert all(t is here for t, _ in inner)


def test_masked_median_equals_numpys_percentiles_on_one_thread_and_two(opencv_threads):
    """The median and the quartiles' σ are numpy's linear percentiles of each pixel's kept
    samples, the same bytes with the kernel's blocks of rows on one thread and on two."""
    rng = np.random.default_rng(11)
    frames = rng.integers(0, 256, size=(13, 11, 6, 3), dtype=np.uint8)
    keep = rng.random((13, 11, 6)) < 0.7
    keep[:, 0, 0] = False                                 # a pixel never kept
    keep[:, 0, 1] = False
    keep[:3, 0, 1] = True                                 # one with too few for a σ
    out = {}
    for n in (1, 2):
        opencv_threads(n)
        out[n] = masked_median(frames, keep, quartiles=True)
    for a, b in zip(out[1], out[2], strict=True):
        assert a.tobytes() == b.tobytes()
    med, count, sigma = out[2]
    for i in range(11):
        for j in range(6):
            k = keep[:, i, j]
            assert count[i, j] == k.sum()
            if not k.any():
                assert (med[i, j] == 0).all() and sigma[i, j] == 0
                continue
            s = frames[k, i, j].astype(float)
            np.testing.assert_allclose(med[i, j], np.percentile(s, 50, axis=0), rtol=1e-6)
            if k.sum() >= 4:
                iqr = np.percentile(s, 75, axis=0) - np.percentile(s, 25, axis=0)
                np.testing.assert_allclose(sigma[i, j], np.sqrt(np.mean((iqr / 1.349) ** 2)),
                                           rtol=1e-5)
            else:
                assert sigma[i, j] == 0


def test_at_most_bounds_how_many_run_at_once(opencv_threads):
    """``at_most=1`` runs every piece in the calling thread; ``at_most=2`` never has more than
    two pieces in flight (counted under a lock while each piece waits a little)."""
    import time

    opencv_threads(4)                                    # a pool of four, were it not bounded
    main = threading.current_thread()
    assert all(t is main for t in threads.each(lambda x: threading.current_thread(), range(5),
                                               at_most=1))
    lock, now, most = threading.Lock(), [0], [0]

    def piece(x):
        with lock:
            now[0] += 1
            most[0] = max(most[0], now[0])
        time.sleep(0.05)
        with lock:
            now[0] -= 1
        return x

    assert threads.each(piece, range(8), at_most=2) == list(range(8))
    assert most[0] <= 2
    most[0] = 0
    threads.each(piece, range(8))
    assert most[0] > 2                                   # unbounded, more did run at once


def _squares():
    return threads.each(lambda x: x * x, range(4))


def test_a_forked_child_makes_its_own_pool(opencv_threads):
    """The parent's pool threads do not survive a fork: a child that used the parent's pool
    object would wait forever (here: the 60 s timeout fails the test)."""
    import multiprocessing

    opencv_threads(2)
    assert _squares() == [0, 1, 4, 9]                   # the parent's pool now exists
    with multiprocessing.get_context("fork").Pool(1) as child:
        assert child.apply_async(_squares).get(timeout=60) == [0, 1, 4, 9]

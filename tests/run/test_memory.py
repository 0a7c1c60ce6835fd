"""``voxelmocap.run.memory``: freed memory handed back to the system between passes."""

import subprocess
import sys
import textwrap

import pytest

from voxelmocap.run import memory

GLIBC = sys.platform.startswith("linux") and memory._malloc_trim() is not None


@pytest.mark.skipif(not GLIBC, reason="needs glibc's malloc_trim and /proc")
def test_freed_heap_memory_goes_back_to_the_system():
    """256 MB of 64 kB buffers (below the allocator's mmap threshold: heap chunks) freed under a
    live one stay resident until the release; after it the process holds what it held before
    they were made (resident memory read from /proc, a fresh interpreter)."""
    script = textwrap.dedent("""
        from voxelmocap.run.memory import release_freed_memory, resident_mib
        start = resident_mib()
        blocks = [bytearray(64_000) for _ in range(4000)]
        keep = bytearray(64_000)          # a live chunk above them: the heap cannot shrink
        made = resident_mib()
        del blocks
        freed = resident_mib()
        released = release_freed_memory()
        print(start, made, freed, resident_mib(), released)
    """)
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                         check=True).stdout.split()
    start, made, freed, after = (float(x) for x in out[:4])
    assert made - start > 200                       # the buffers were resident
    assert out[4] == "True"
    assert after < start + 40 < freed               # retained when freed, returned by the call


def test_without_malloc_trim_nothing_is_done(monkeypatch):
    """A C library without ``malloc_trim`` (macOS, Windows, musl): False, no error."""
    monkeypatch.setattr(memory, "_malloc_trim", lambda: None)
    assert memory.release_freed_memory() is False


def test_resident_memory_is_read_or_none():
    """A positive number of MiB where /proc exists, else None."""
    mib = memory.resident_mib()
    assert mib is None or mib > 0

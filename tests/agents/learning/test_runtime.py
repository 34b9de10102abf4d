"""The training process's allocator setting: a freed large block stays with the process."""

from __future__ import annotations

import platform
import subprocess
import sys
import textwrap

import pytest

# In a fresh interpreter (this process's earlier tests move glibc's dynamic thresholds): with
# or without keep_freed_memory(), malloc 24 MiB, touch it, free it, and report what glibc held
# in newly mmapped blocks meanwhile and what the heap holds free afterwards (mallinfo2, glibc
# 2.33 and later).
PROBE = textwrap.dedent(
    """
    import ctypes, sys
    from agents.learning.runtime import keep_freed_memory

    class MallInfo2(ctypes.Structure):
        _fields_ = [(name, ctypes.c_size_t) for name in (
            "arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks", "fsmblks",
            "uordblks", "fordblks", "keepcost")]

    libc = ctypes.CDLL(None)
    libc.mallinfo2.restype = MallInfo2
    libc.malloc.restype = ctypes.c_void_p
    libc.malloc.argtypes = [ctypes.c_size_t]
    libc.free.argtypes = [ctypes.c_void_p]
    took = keep_freed_memory() if sys.argv[1] == "keep" else None
    size = 24 << 20
    mapped_before = libc.mallinfo2().hblkhd
    block = libc.malloc(size)
    ctypes.memset(block, 1, size)
    mapped = libc.mallinfo2().hblkhd - mapped_before
    libc.free(block)
    print(took, mapped >> 20, libc.mallinfo2().fordblks >> 20)
    """
)


def _probe(mode: str) -> list[str]:
    out = subprocess.run(
        [sys.executable, "-c", PROBE, mode], capture_output=True, text=True, check=True
    )
    return out.stdout.split()


def _glibc_version() -> tuple[int, ...]:
    name, version = platform.libc_ver()
    return tuple(int(part) for part in version.split(".")) if name == "glibc" else ()


glibc = pytest.mark.skipif(
    _glibc_version() < (2, 33), reason="mallinfo2 is glibc's (2.33 and later)"
)


@glibc
def test_a_freed_large_block_stays_in_the_heap_once_kept() -> None:
    took, mapped_mib, free_mib = _probe("keep")
    assert took == "True"
    assert int(mapped_mib) == 0  # served from the heap, not mmapped
    assert int(free_mib) >= 24  # and kept there once freed: the next minibatch reuses it


@glibc
def test_without_it_glibc_maps_the_block_and_gives_it_back() -> None:
    took, mapped_mib, free_mib = _probe("default")
    assert took == "None"
    assert int(mapped_mib) >= 24
    assert int(free_mib) < 24


def test_calling_it_again_is_harmless() -> None:
    from agents.learning.runtime import keep_freed_memory

    first = keep_freed_memory()
    assert keep_freed_memory() == first

"""Peak memory of the current process, for the tests that bound it.

Not `resource.getrusage(...).ru_maxrss`: Linux carries the parent's high-water RSS across
fork/vfork + exec into the child's ru_maxrss (fs/exec.c, exec_mmap), so a test process started
from a 2.4 GB pytest reports at least 2.4 GB whatever it did itself. VmHWM in /proc/self/status
is the high-water mark of this process's own address space, fresh at exec."""

from __future__ import annotations


def peak_rss_mb() -> float:
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024.0  # kB
    raise RuntimeError("no VmHWM in /proc/self/status")

"""A process's CPU time and the machine's load from /proc, for the benchmarks that watch node processes."""

from __future__ import annotations

import os
import subprocess
import sys

CLOCK_TICK = os.sysconf("SC_CLK_TCK")


def cpu_seconds(pid: int) -> float:
    """utime + stime of every thread of the process (fields 14 and 15 of /proc/<pid>/stat)."""
    with open(f"/proc/{pid}/stat", encoding="ascii") as handle:
        fields = handle.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / CLOCK_TICK


def loadavg() -> str:
    """The 1-minute load average, as /proc/loadavg gives it."""
    with open("/proc/loadavg", encoding="ascii") as handle:
        return handle.read().split()[0]


def start_stress(count: int) -> list[subprocess.Popen]:
    """count busy-loop processes, each taking a core if it can: the load a benchmark runs beside."""
    return [subprocess.Popen([sys.executable, "-c", "while True: pass"], start_new_session=True)
            for _ in range(count)]


def stop_stress(processes: list[subprocess.Popen]) -> None:
    for process in processes:
        process.kill()
        process.wait()

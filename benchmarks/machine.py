"""The machine line the benchmarks print above their tables (imported by the scripts beside it)."""

import importlib.metadata
import os
import platform


def machine_line() -> str:
    """Architecture, CPU model, cores, Python and Drake versions."""
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return (
        f"{platform.machine()}, {cpu}, {os.cpu_count()} cores, Python "
        f"{platform.python_version()}, drake {importlib.metadata.version('drake')}"
    )

"""What the benchmarks share (imported by the scripts beside it): the machine line they print
above their tables, and writing a results file."""

import importlib.metadata
import os
import pathlib
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


def write_results(path: pathlib.Path, lines: list[str]) -> None:
    """Prints the results' lines and writes them to path (a file under benchmarks/results/)."""
    text = "\n".join(lines) + "\n"
    print(text, end="")
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)

"""What the benchmarks share (imported by the scripts beside it): the machine line they print
above their tables, writing a results file (keeping its hand-written section), and timing a
method in place."""

import importlib.metadata
import os
import pathlib
import platform
import time


def machine_line() -> str:
    """Architecture, CPU model (with its family and model numbers and whether it has AVX-512:
    a virtual machine may name every generation alike, and BLAS and solver kernels differ by
    them), cores, Python and Drake versions."""
    cpu = platform.processor() or platform.machine()
    info = {}
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                key, _, value = line.partition(":")
                info.setdefault(key.strip(), value.strip())
                if not line.strip():
                    break  # the first processor is enough
    except OSError:
        pass
    if "model name" in info:
        avx512 = "AVX-512" if "avx512f" in info.get("flags", "").split() else "no AVX-512"
        cpu = (
            f"{info['model name']} (family {info.get('cpu family', '?')}, model "
            f"{info.get('model', '?')}, {avx512})"
        )
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


def with_notes(path: pathlib.Path, lines: list[str], heading: str) -> list[str]:
    """lines, then the section of the results file at path that starts at `heading` (its
    hand-written reading of the numbers), so that a rerun keeps it; lines alone if none."""
    if path.exists():
        old = path.read_text()
        if heading in old:
            return [*lines, "", heading + old.split(heading, 1)[1].rstrip("\n")]
    return lines


def timed(cls, name: str):
    """Wraps cls.name to add up its wall time; returns (restore, [total seconds])."""
    total = [0.0]
    original = getattr(cls, name)

    def wrapper(*args, **kwargs):
        start = time.perf_counter()
        try:
            return original(*args, **kwargs)
        finally:
            total[0] += time.perf_counter() - start

    setattr(cls, name, wrapper)
    return (lambda: setattr(cls, name, original)), total


def best_of_alternating(run, case, reference, repeat: int) -> tuple[dict, dict]:
    """(best, best reference): run(case) and run(reference) `repeat` times each, alternating
    which goes first, each the run with the highest summary real_time_factor."""
    full, ref = [], []
    for r in range(repeat):
        pair = [(full, case), (ref, reference)]
        for bucket, scenario in pair if r % 2 == 0 else pair[::-1]:
            bucket.append(run(scenario))

    def best(runs):
        return max(runs, key=lambda m: m["summary"]["real_time_factor"])

    return best(full), best(ref)

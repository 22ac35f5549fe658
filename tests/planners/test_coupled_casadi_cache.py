"""The CasADi derivative cache (rpod.planners.coupled_casadi.compile_functions): a compiled
library is loaded only when its SHA-256 matches the one written beside it after its compile,
and the cache is a private folder of this user; anything else is compiled again, or, when that
is impossible, the virtual machine is used with a warning, never a traceback or a crash.

The code path is the NMPC's (compile_functions), on a small CasADi function (2 x) that
compiles in a fraction of a second, into a cache under tmp_path (RPOD_CACHE_DIR); each test has
its own, so no library path is loaded twice into this process. A damaged library that the old
code would have loaded (a truncated one kills the process with SIGBUS) is only ever loaded in a
subprocess.
"""

import logging
import os
import shutil
import stat
import subprocess
import sys
import textwrap

import casadi as ca
import numpy as np
import pytest

from rpod.planners import coupled_casadi as cc

pytestmark = pytest.mark.skipif(
    shutil.which("gcc") is None and shutil.which("cc") is None, reason="no C compiler"
)

NAME = "probe"


def twice() -> ca.Function:
    x = ca.SX.sym("x", 3)
    return ca.Function("probe_scale", [x], [2 * x])


def thrice() -> ca.Function:
    """Another function under the same name: a library somebody put in the cache."""
    x = ca.SX.sym("x", 3)
    return ca.Function("probe_scale", [x], [3 * x])


def value(function) -> list[float]:
    return np.array(function([1.0, 2.0, 3.0])).ravel().tolist()


class _Said(logging.Handler):
    def __init__(self):
        super().__init__(logging.DEBUG)
        self.records = []

    def emit(self, record):
        self.records.append(record)

    def warnings(self) -> list[str]:
        return [r.getMessage() for r in self.records if r.levelno >= logging.WARNING]


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """(the cache folder, what rpod.compile said) with RPOD_CACHE_DIR under tmp_path."""
    monkeypatch.setenv("RPOD_CACHE_DIR", str(tmp_path / "root"))
    said = _Said()
    log = logging.getLogger("rpod.compile")
    monkeypatch.setattr(log, "level", logging.INFO)
    monkeypatch.setattr(log, "handlers", [*log.handlers, said])
    return tmp_path / "root" / "casadi", said


def compiled(function=None):
    """(the compiled function or the given one, message) of compile_functions."""
    (result,), message = cc.compile_functions([function or twice()], NAME)
    return result, message


def library_of(message: str):
    assert message.startswith("compiled derivatives "), message
    return cc.pathlib.Path(message.removeprefix("compiled derivatives "))


def test_a_compile_writes_the_checksum_beside_the_library_in_a_private_folder(cache):
    folder, said = cache
    function, message = compiled()
    library = library_of(message)
    assert library.parent == folder and value(function) == [2.0, 4.0, 6.0]
    assert cc.checksum_path(library).read_text().strip() == cc._sha256(library)
    assert stat.S_IMODE(os.stat(folder).st_mode) == 0o700
    again, message_again = compiled()  # found in the cache, verified, not compiled again
    assert message_again == message and value(again) == [2.0, 4.0, 6.0]
    assert len([r for r in said.records if "compiling" in r.getMessage()]) == 1
    assert not said.warnings()


def test_a_cache_folder_an_older_rpod_made_readable_is_made_private(cache):
    folder, _ = cache
    folder.mkdir(parents=True, mode=0o755)
    os.chmod(folder, 0o755)
    compiled()
    assert stat.S_IMODE(os.stat(folder).st_mode) == 0o700


TRUNCATED_RUN = textwrap.dedent(
    """
    import sys
    import casadi as ca
    import numpy as np
    from rpod.planners import coupled_casadi as cc
    x = ca.SX.sym("x", 3)
    (f,), message = cc.compile_functions([ca.Function("probe_scale", [x], [2 * x])], "probe")
    print(message)
    print(np.array(f([1.0, 2.0, 3.0])).ravel().tolist())
    """
)


def test_a_truncated_library_is_compiled_again_not_loaded(cache, tmp_path):
    folder, _ = cache
    env = {**os.environ, "RPOD_CACHE_DIR": str(folder.parent)}
    first = subprocess.run(
        [sys.executable, "-c", TRUNCATED_RUN], env=env, capture_output=True, text=True, check=False
    )
    assert first.returncode == 0, first.stderr
    library = library_of(first.stdout.splitlines()[0])
    data = library.read_bytes()
    library.write_bytes(data[: len(data) // 2])  # as a full disk or a killed copy leaves it
    second = subprocess.run(
        [sys.executable, "-c", TRUNCATED_RUN], env=env, capture_output=True, text=True, check=False
    )
    # Loaded, the truncated library killed the process with SIGBUS (status -7), saying nothing.
    assert second.returncode == 0, (second.returncode, second.stderr)
    assert second.stdout.splitlines() == first.stdout.splitlines()
    assert "did not match its checksum" in second.stderr
    assert library.read_bytes() == data


@pytest.mark.parametrize(
    "damage",
    [
        lambda data: bytes(b ^ 0x5A for b in data),  # corrupt: every byte changed
        lambda data: data[:100] + b"\0" * (len(data) - 100),  # corrupt: zeros after the header
        lambda data: b"",  # empty
    ],
    ids=["corrupt", "zeroed", "empty"],
)
def test_a_damaged_library_is_compiled_again(cache, tmp_path, damage):
    folder, said = cache
    # The first compile goes to another cache, so that this process never loads the library
    # path it damages (the loader would reuse the mapping of a path it has already loaded).
    library = folder / library_of(_compile_elsewhere(tmp_path / "first", twice())).name
    folder.mkdir(parents=True, mode=0o700)
    source = tmp_path / "first" / "casadi" / library.name
    library.write_bytes(damage(source.read_bytes()))
    shutil.copy(cc.checksum_path(source), cc.checksum_path(library))
    function, message = compiled()
    assert library_of(message) == library and value(function) == [2.0, 4.0, 6.0]
    assert library.read_bytes() == source.read_bytes()
    assert any("did not match its checksum" in w for w in said.warnings()), said.warnings()


def _compile_elsewhere(root, function) -> str:
    """compile_functions' message for function, compiled into the cache under root."""
    previous = os.environ["RPOD_CACHE_DIR"]
    os.environ["RPOD_CACHE_DIR"] = str(root)
    try:
        return compiled(function)[1]
    finally:
        os.environ["RPOD_CACHE_DIR"] = previous


@pytest.mark.parametrize("checksum", ["none", "made_up", "of_rpods_compile"])
def test_a_library_put_in_the_cache_under_the_expected_name_never_runs(cache, tmp_path, checksum):
    folder, _ = cache
    library = folder / library_of(_compile_elsewhere(tmp_path / "good", twice())).name
    planted = library_of(_compile_elsewhere(tmp_path / "other", thrice()))
    assert planted.name != library.name  # another source, another key
    folder.mkdir(parents=True, mode=0o700)
    shutil.copy(planted, library)  # somebody's library under the name rpod will look for
    if checksum == "made_up":
        cc.checksum_path(library).write_text("0" * 64 + "\n")
    elif checksum == "of_rpods_compile":  # the checksum of the library rpod compiled
        shutil.copy(tmp_path / "good" / "casadi" / cc.checksum_path(library).name, folder)
    function, message = compiled()
    assert value(function) == [2.0, 4.0, 6.0], "the planted library ran"
    assert library_of(message) == library and cc.verified(library)


def _fell_back(function, message, said, because: str):
    assert function.name() == "probe_scale" and value(function) == [2.0, 4.0, 6.0]
    assert message.startswith("cache ") and "virtual machine" in message, message
    warnings = said.warnings()
    assert len(warnings) == 1 and because in warnings[0], warnings


def test_a_file_where_the_cache_folder_should_be_falls_back_with_one_warning(cache):
    folder, said = cache
    folder.parent.mkdir(parents=True)
    folder.write_text("not a folder")
    original = twice()
    function, message = compiled(original)
    assert function is original  # CasADi's virtual machine: the function as given
    _fell_back(function, message, said, str(folder))
    assert folder.read_text() == "not a folder"


def test_a_file_where_the_cache_root_should_be_falls_back(cache):
    folder, said = cache
    folder.parent.write_text("not a folder")
    function, message = compiled()
    _fell_back(function, message, said, "cannot be used")


def test_a_cache_folder_other_users_can_write_is_not_used(cache):
    folder, said = cache
    folder.mkdir(parents=True)
    os.chmod(folder, 0o777)
    function, message = compiled()
    _fell_back(function, message, said, "other users can write to it")
    assert not list(folder.iterdir())  # nothing compiled into it


def test_a_cache_folder_of_another_user_is_not_used(cache, monkeypatch):
    folder, said = cache
    folder.mkdir(parents=True, mode=0o700)
    monkeypatch.setattr(os, "geteuid", lambda: os.stat(folder).st_uid + 1)  # we are not its owner
    function, message = compiled()
    _fell_back(function, message, said, "belongs to another user")


def test_a_cache_where_nothing_can_be_written_falls_back(cache, monkeypatch):
    folder, said = cache

    def refuse(*args, **kwargs):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(cc.tempfile, "TemporaryDirectory", _only_outside(folder, refuse))
    function, message = compiled()
    _fell_back(function, message, said, "Permission denied")


def _only_outside(folder, refuse):
    """tempfile.TemporaryDirectory, refused inside folder (a cache that cannot be written)."""
    real = cc.tempfile.TemporaryDirectory

    def temporary_directory(*args, dir=None, **kwargs):
        if dir is not None and os.path.samefile(dir, folder):
            return refuse()
        return real(*args, dir=dir, **kwargs)

    return temporary_directory


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into a read-only folder")
def test_a_read_only_cache_folder_falls_back(cache):
    folder, said = cache
    folder.mkdir(parents=True, mode=0o700)
    os.chmod(folder, 0o500)
    try:
        function, message = compiled()
    finally:
        os.chmod(folder, 0o700)
    _fell_back(function, message, said, "Permission denied")


def test_a_damaged_library_that_cannot_be_removed_falls_back(cache, tmp_path, monkeypatch):
    folder, said = cache
    library = folder / library_of(_compile_elsewhere(tmp_path / "first", twice())).name
    folder.mkdir(parents=True, mode=0o700)
    library.write_bytes(b"\x7fELF truncated")

    def refuse(self, *args, **kwargs):
        raise PermissionError(13, "Permission denied", str(self))

    monkeypatch.setattr(cc.pathlib.Path, "unlink", refuse)
    function, message = compiled()
    _fell_back(function, message, said, "Permission denied")
    assert library.read_bytes() == b"\x7fELF truncated"  # never loaded

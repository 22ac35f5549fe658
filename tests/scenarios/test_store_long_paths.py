"""Paths too long for the file system, or just long, given as RESULTS or --out to `rpod report`
and `rpod sweep`: one short line naming the flag or path (cut), never an OSError traceback and
never the whole path echoed."""

import pathlib

import pytest

from rpod.scenarios.loader import ScenarioFileError
from rpod.scenarios.store import STORE_NAME, ResultStore, make_folder

TOO_LONG = "y" * 4000  # a file name past NAME_MAX (255): stat() raises ENAMETOOLONG


def _short_one_line(error) -> str:
    message = str(error.value)
    assert "\n" not in message and len(message) < 300, message
    assert "y" * 250 not in message, message
    return message


def test_make_folder_with_a_name_too_long(tmp_path):
    with pytest.raises(ScenarioFileError) as error:
        make_folder(tmp_path / TOO_LONG / "plots")
    assert _short_one_line(error).startswith("--out ")


def test_open_existing_with_a_name_too_long(tmp_path):
    for results in (TOO_LONG, str(tmp_path / TOO_LONG)):
        with pytest.raises(ScenarioFileError, match="cannot be read") as error:
            ResultStore.open_existing(results)
        _short_one_line(error)


def test_check_compatible_with_a_name_too_long(tmp_path):
    with pytest.raises(ScenarioFileError) as error:
        ResultStore.check_compatible(pathlib.Path(tmp_path, TOO_LONG, STORE_NAME), "f", 1)
    assert _short_one_line(error).startswith("--out ")

"""`rpod run --export ccsds` and `rpod export RUN`: CCSDS OEM and AEM read back to the log.

A 60 s `coast` run (no recording, no plots: ~1.5 s) at a stated epoch, exported by the run
itself, is shared by the module. Every file is read back with the package that wrote it
(ccsds-ndm-py, `ccsds_ndm`) and compared with log.npz. Tolerances: the files hold each double's
shortest repr, which reads back to the same double, so quaternions compare exactly and the
states lose only the m -> km division and its inverse (a few ulp of 6.9e6 m: 1e-8 m and
1e-11 m/s are loose bounds). Epochs are epoch_utc + t rounded to the nanosecond (0.5 ns).
"""

import ccsds_ndm
import numpy as np
import pytest
from campaign_helpers import run_rpod_in_process

from rpod.scenarios.export import export_ccsds
from rpod.scenarios.loader import ScenarioFileError

EPOCH = "2024-03-20T03:06:00.5"  # not the default, so the test sees it travel
SETS = ["--set", "duration_s=60", "--set", f"orbit.epoch_utc='{EPOCH}'"]
POSITION_TOLERANCE_M = 1e-8
VELOCITY_TOLERANCE_M_S = 1e-11


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    folder = tmp_path_factory.mktemp("export")
    out = folder / "run"
    process = run_rpod_in_process(
        "run", "coast", *SETS, "--no-record", "--no-plots", "--export", "ccsds", "--out", out,
        cwd=folder,
    )  # fmt: skip
    assert process.returncode == 0, process.stderr
    lines = process.stdout.splitlines()
    assert len(lines) == 2 and "chaser.oem, target.oem, chaser.aem, target.aem" in lines[1], lines
    return out


def _seconds_since(epochs: list[str], epoch: str) -> np.ndarray:
    delta = np.array(epochs, dtype="datetime64[ns]") - np.datetime64(epoch, "ns")
    return delta.astype(np.int64) * 1e-9


@pytest.mark.parametrize("body, frame", [("chaser", "C"), ("target", "T")])
def test_oem_reads_back_to_the_logged_states(run_dir, body, frame):
    log = np.load(run_dir / "log.npz")
    oem = ccsds_ndm.Oem.from_file(str(run_dir / "ccsds" / f"{body}.oem"))
    (segment,) = oem.segments
    meta = segment.metadata
    assert (meta.ref_frame, meta.center_name, meta.time_system) == ("EME2000", "EARTH", "UTC")
    assert meta.object_name == body.upper()
    states_km = segment.data.state_vector_numpy
    np.testing.assert_allclose(
        states_km[:, :3] * 1e3, log[f"p_I{frame}_I"], rtol=0, atol=POSITION_TOLERANCE_M
    )
    np.testing.assert_allclose(
        states_km[:, 3:] * 1e3, log[f"v_I{frame}_I"], rtol=0, atol=VELOCITY_TOLERANCE_M_S
    )
    epochs = segment.data.state_vector_epochs
    assert np.datetime64(epochs[0], "ns") == np.datetime64(EPOCH, "ns")  # the scenario's epoch
    np.testing.assert_allclose(_seconds_since(epochs, EPOCH), log["t"], rtol=0, atol=0.5e-9)
    assert (meta.start_time, meta.stop_time) == (epochs[0], epochs[-1])


@pytest.mark.parametrize("body, frame", [("chaser", "C"), ("target", "T")])
def test_aem_reads_back_to_the_logged_quaternions_scalar_last(run_dir, body, frame):
    log = np.load(run_dir / "log.npz")
    path = run_dir / "ccsds" / f"{body}.aem"
    aem = ccsds_ndm.Aem.from_file(str(path))
    (segment,) = aem.segments
    meta = segment.metadata
    assert (meta.ref_frame_a, meta.ref_frame_b, meta.time_system) == ("EME2000", "SC_BODY_1", "UTC")
    assert meta.attitude_type == "QUATERNION"
    q_wxyz = log[f"q_I{frame}"]
    np.testing.assert_array_equal(segment.data.attitude_states_numpy, q_wxyz[:, [1, 2, 3, 0]])
    epochs = segment.data.attitude_states_epochs
    np.testing.assert_allclose(_seconds_since(epochs, EPOCH), log["t"], rtol=0, atol=0.5e-9)
    # The order on the line itself, which a writer and reader sharing one mistake (QC first, as
    # another package writes AEM 2.0) would hide: EPOCH Q1 Q2 Q3 QC.
    lines = path.read_text().splitlines()
    first = lines[lines.index("DATA_START") + 1].split()
    assert [float(x) for x in first[1:]] == list(q_wxyz[0, [1, 2, 3, 0]])
    assert "REF_FRAME_A (EME2000" in path.read_text()  # the direction said in a COMMENT


def test_the_run_folder_stays_rpods_with_the_export_in_its_manifest(run_dir):
    import json

    from rpod.scenarios.run import check_out_dir

    entries = json.loads((run_dir / ".rpod-output").read_text())["entries"]
    assert {"ccsds", "ccsds/chaser.oem", "ccsds/target.aem"} <= set(entries)
    check_out_dir(run_dir)  # a new `rpod run --out RUN` may replace it without --overwrite


def test_rpod_export_writes_where_told_in_one_line(run_dir, tmp_path):
    out = tmp_path / "elsewhere"
    process = run_rpod_in_process("export", run_dir, "--out", out, cwd=tmp_path)
    assert process.returncode == 0, process.stderr
    assert process.stdout.count("\n") == 1 and str(out) in process.stdout
    assert sorted(p.name for p in out.iterdir()) == sorted(
        ["chaser.oem", "target.oem", "chaser.aem", "target.aem"]
    )
    again = ccsds_ndm.Oem.from_file(str(out / "target.oem")).segments[0].data
    first = ccsds_ndm.Oem.from_file(str(run_dir / "ccsds" / "target.oem")).segments[0].data
    np.testing.assert_array_equal(again.state_vector_numpy, first.state_vector_numpy)


@pytest.mark.parametrize("what", ["missing", "empty", "no_scenario"])
def test_a_folder_that_is_not_a_run_is_one_line_naming_it(run_dir, tmp_path, what):
    folder = tmp_path / what
    if what != "missing":
        folder.mkdir()
    if what == "no_scenario":
        (folder / "log.npz").write_bytes((run_dir / "log.npz").read_bytes())
    with pytest.raises(ScenarioFileError, match=str(folder)) as error:
        export_ccsds(folder)
    assert "\n" not in str(error.value)
    process = run_rpod_in_process("export", folder, cwd=tmp_path)
    assert process.returncode == 2
    assert process.stderr.count("\n") == 1 and str(folder) in process.stderr
    assert not (folder / "ccsds").exists()


def test_free_space_is_refused_before_the_run(tmp_path):
    out = tmp_path / "run"
    process = run_rpod_in_process(
        "run", "planar_approach", "--export", "ccsds", "--out", out, cwd=tmp_path
    )
    assert process.returncode == 2 and "free_space" in process.stderr, process.stderr
    assert not out.exists()


def test_the_epoch_changes_no_truth(run_dir, tmp_path):
    """The same run at the default epoch logs the same numbers: the epoch only labels time."""
    out = tmp_path / "run"
    process = run_rpod_in_process(
        "run", "coast", "--set", "duration_s=60", "--no-record", "--no-plots", "--out", out,
        cwd=tmp_path,
    )  # fmt: skip
    assert process.returncode == 0, process.stderr
    here, there = np.load(out / "log.npz"), np.load(run_dir / "log.npz")
    assert here.files == there.files
    for key in here.files:
        np.testing.assert_array_equal(here[key], there[key], err_msg=key)


def test_the_command_line_offers_the_formats_export_writes():
    from rpod.scenarios import cli, export

    assert cli.EXPORT_FORMATS == export.FORMATS

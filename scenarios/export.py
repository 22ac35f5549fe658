"""A run's trajectories as CCSDS messages: chaser and target as OEM, their attitudes as AEM.

Owns: `export_ccsds`, which reads a run folder (log.npz and scenario.yaml, as `rpod run` writes
them) and writes `chaser.oem`, `target.oem` (Orbit Ephemeris Messages, CCSDS 502.0-B-3) and
`chaser.aem`, `target.aem` (Attitude Ephemeris Messages, CCSDS 504.0-B-2), all in KVN text;
and `check_exportable`, the scenario check `rpod run --export ccsds` makes before it flies.
Does not own: running (run.py), the command line (cli.py), the epoch field (rpod.models.orbit).

What the files say, and what they do not:
- Frame. rpod's inertial frame I is an idealised Earth-centred inertial frame: origin at the
  Earth's centre of mass, z along the Earth's spin axis (the J2 axis), not rotating. The truth
  models no precession, nutation or polar motion, so I has no epoch of its own; the files label
  it `EME2000` so that tools read it, and a header COMMENT says it is EME2000-like only in this
  sense. CENTER_NAME is EARTH. A free-space scenario has no Earth: it is refused.
- Time. TIME_SYSTEM is UTC: a state's epoch is `orbit.epoch_utc` plus its simulated time `t`,
  rounded to the nanosecond, counted without leap seconds (a run that spans one is off by a
  second after it). A sample repeated at the same instant is written once (epochs must grow).
- Units. Positions in km and velocities in km/s, as CCSDS OEM requires (the log is in m, m/s).
  Numbers are written as Python's shortest repr of each double, so they read back exactly.
- Attitude. ATTITUDE_TYPE QUATERNION from REF_FRAME_A = EME2000 (I) to REF_FRAME_B = SC_BODY_1
  (the body frame: C for the chaser, T for the target). In AEM 2.0 the rotation always goes from
  A to B and the scalar part QC comes last (`EPOCH Q1 Q2 Q3 QC`). rpod's q_IC (w, x, y, z) is the
  rotation that turns I's axes onto C's (R_IC maps C-vectors into I); that is CCSDS's rotation
  from A to B, so Q1 Q2 Q3 QC = x y z w of the logged quaternion, with its sign as logged.

Why ccsds-ndm-py (PyPI `ccsds-ndm-py`, imported as `ccsds_ndm`: a Rust core with Python
bindings). It reads and writes every NDM message, OEM and AEM included, in KVN and XML, takes
and gives numpy arrays, and writes AEM 2.0 quaternions scalar last as the standard says. The
alternatives, tried: `oem` writes OEM only (no AEM) and pulls in astropy; `ccsds-ndm` (the
xsdata one, GPL-3) writes AEM 2.0 KVN with QC first and cannot read that KVN back (its XML is
right), and parses 30,000 KVN states in ~14 s against ~0.03 s here. Its risk: a young package
(0.0.x), hence the bounded version in pyproject.toml; the tests read every file back with it.

Where the files go. `out_dir` (default RUN/ccsds/) is created if needed; the four files are each
written whole (a temporary name, then a rename) and replace files of the same names; nothing else
there is touched. When out_dir is inside the run folder and the folder has rpod's manifest
(rpod.scenarios.run, `.rpod-output`), the new names are added to it, so the folder stays rpod's
and `rpod run --out RUN` may replace it again without --overwrite.
"""

import contextlib
import datetime
import json
import os
import pathlib
import zipfile

import numpy as np

from rpod.models.orbit import epoch_utc_datetime64
from rpod.scenarios.loader import ScenarioFileError, parse_scenario
from rpod.scenarios.run import MANIFEST
from rpod.scenarios.schema import quote

FORMATS = ("ccsds",)
FILE_NAMES = ("chaser.oem", "target.oem", "chaser.aem", "target.aem")
LOG_KEYS = ("t", "p_IT_I", "v_IT_I", "p_IC_I", "v_IC_I", "q_IT", "q_IC")
REF_FRAME = "EME2000"
BODY_FRAME = "SC_BODY_1"
FRAME_COMMENTS = [
    "REF_FRAME EME2000 labels rpod's idealised Earth-centred inertial frame I: origin at the",
    "Earth's centre, z along the Earth's spin (J2) axis, not rotating. rpod's truth models no",
    "precession, nutation or polar motion, so I is EME2000 only to that extent.",
]
ATTITUDE_COMMENTS = [
    "Quaternion of the rotation from REF_FRAME_A (EME2000, rpod's I) to REF_FRAME_B (SC_BODY_1,",
    "the body frame): Q1 Q2 Q3 = axis * sin(angle/2), QC = cos(angle/2), scalar last.",
    "It equals rpod's logged q_I<body> (w, x, y, z) as x y z w: R_I<body> maps body vectors to I.",
]


def _q(path) -> str:
    return quote(str(path), 200)


def check_exportable(scenario, source: str) -> None:
    """ScenarioFileError unless the scenario's trajectories can be written as CCSDS (an Earth)."""
    if scenario.orbit.gravity == "free_space":
        raise ScenarioFileError(
            f"{source}: orbit.gravity is free_space: no Earth-centred trajectory to export as CCSDS"
        )


def _read_run(run: pathlib.Path):
    """(scenario, log arrays, scenario name) of a run folder; ScenarioFileError if it is not one."""
    if not run.is_dir():
        raise ScenarioFileError(f"{_q(run)}: not a folder (expected an rpod run folder)")
    for name in ("log.npz", "scenario.yaml"):
        if not (run / name).is_file():
            raise ScenarioFileError(
                f"{_q(run)}: not an rpod run folder: it has no {name} (rpod run writes one)"
            )
    try:
        text = (run / "scenario.yaml").read_text()
    except (OSError, UnicodeDecodeError) as error:
        raise ScenarioFileError(f"{_q(run / 'scenario.yaml')}: cannot read: {error}") from None
    scenario = parse_scenario(text, str(run / "scenario.yaml"))
    check_exportable(scenario, str(run / "scenario.yaml"))
    try:
        with np.load(run / "log.npz") as data:
            missing = [key for key in LOG_KEYS if key not in data.files]
            log = {key: np.asarray(data[key], dtype=float) for key in LOG_KEYS if key in data}
    except (OSError, ValueError, zipfile.BadZipFile) as error:
        raise ScenarioFileError(f"{_q(run / 'log.npz')}: cannot read: {error}") from None
    if missing:
        raise ScenarioFileError(f"{_q(run / 'log.npz')}: has no {', '.join(missing)}")
    if not all(np.all(np.isfinite(values)) for values in log.values()):
        raise ScenarioFileError(f"{_q(run / 'log.npz')}: holds non-finite states")
    name = run.resolve().name
    with contextlib.suppress(OSError, ValueError, AttributeError):  # the name the run was given
        name = str(json.loads((run / "summary.json").read_text()).get("scenario", name))
    return scenario, log, name


def _epochs(epoch_utc: str, t: np.ndarray) -> tuple[list[str], np.ndarray]:
    """(ISO strings to the ns, the rows kept): epoch_utc + t, each instant once, growing."""
    epochs = epoch_utc_datetime64(epoch_utc) + np.round(t * 1e9).astype("timedelta64[ns]")
    keep = np.concatenate([[True], np.diff(epochs) > np.timedelta64(0, "ns")])
    return list(np.datetime_as_string(epochs[keep], unit="ns")), keep


def _messages(scenario, log: dict, name: str) -> dict[str, str]:
    """File name -> KVN text of the four messages."""
    import ccsds_ndm  # ccsds-ndm-py: only when exporting

    epochs, keep = _epochs(scenario.orbit.epoch_utc, log["t"])
    created = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%S")
    about = f"rpod truth of scenario {name}; epochs: orbit.epoch_utc {scenario.orbit.epoch_utc} + t"
    span = {"start_time": epochs[0], "stop_time": epochs[-1], "time_system": "UTC"}
    texts = {}
    for body, frame in (("chaser", "C"), ("target", "T")):
        ids = {"object_name": body.upper(), "object_id": f"RPOD-{body.upper()}"}
        state_km = np.hstack([log[f"p_I{frame}_I"], log[f"v_I{frame}_I"]])[keep] / 1000.0
        oem = ccsds_ndm.Oem(
            ccsds_ndm.OdmHeader(
                creation_date=created, originator="rpod", comment=[about, *FRAME_COMMENTS]
            ),
            [
                ccsds_ndm.OemSegment(
                    ccsds_ndm.OemMetadata(**ids, **span, center_name="EARTH", ref_frame=REF_FRAME),
                    ccsds_ndm.OemData.from_numpy(epochs, state_km),
                )
            ],
        )
        quaternion = log[f"q_I{frame}"][keep][:, [1, 2, 3, 0]]  # w x y z -> Q1 Q2 Q3 QC
        aem = ccsds_ndm.Aem(
            ccsds_ndm.AdmHeader(
                creation_date=created,
                originator="rpod",
                comment=[about, *FRAME_COMMENTS, *ATTITUDE_COMMENTS],
            ),
            [
                ccsds_ndm.AemSegment(
                    ccsds_ndm.AemMetadata(
                        **ids,
                        **span,
                        center_name="EARTH",
                        ref_frame_a=REF_FRAME,
                        ref_frame_b=BODY_FRAME,
                        attitude_type="QUATERNION",
                    ),
                    ccsds_ndm.AemData.from_numpy(epochs, quaternion, attitude_type="QUATERNION"),
                )
            ],
        )
        texts[f"{body}.oem"], texts[f"{body}.aem"] = oem.to_str("kvn"), aem.to_str("kvn")
    return texts


def _write_whole(path: pathlib.Path, text: str) -> None:
    """text into path under a temporary name first, so path is never left half-written."""
    partial = path.with_name(f".{path.name}.partial-{os.getpid()}")
    try:
        partial.write_text(text)
        os.replace(partial, path)
    except BaseException:
        partial.unlink(missing_ok=True)
        raise


def _add_to_manifest(run: pathlib.Path, written: list[pathlib.Path]) -> None:
    """The written files (and their folders) listed in run's manifest, if it has rpod's."""
    manifest_path = run / MANIFEST
    try:
        manifest = json.loads(manifest_path.read_text())
        entries = set(manifest["entries"])
    except (OSError, ValueError, KeyError, TypeError):
        return  # no manifest (or not rpod's): nothing to keep in step
    if manifest.get("written_by") != "rpod":
        return
    for path in written:
        relative = path.relative_to(run)
        entries.update(p.as_posix() for p in [relative, *relative.parents] if p.name)
    manifest["entries"] = sorted(entries)
    _write_whole(manifest_path, json.dumps(manifest, indent=1) + "\n")


def export_ccsds(run_folder, out_dir=None) -> list[pathlib.Path]:
    """Writes a run's chaser and target as CCSDS OEM and AEM files (module docstring).

    Args:
        run_folder: A folder `rpod run` wrote (log.npz and scenario.yaml are read).
        out_dir: Where to write (default: RUN/ccsds/); created if needed.

    Returns:
        The paths written: chaser.oem, target.oem, chaser.aem, target.aem.

    Raises:
        ScenarioFileError: One line naming the path, when the folder is not a run (no such
            folder, no log.npz or scenario.yaml, a free-space scenario) or cannot be written.
    """
    run = pathlib.Path(run_folder)
    scenario, log, name = _read_run(run)
    texts = _messages(scenario, log, name)
    out = pathlib.Path(out_dir) if out_dir is not None else run / "ccsds"
    written = []
    try:
        out.mkdir(parents=True, exist_ok=True)
        for file_name in FILE_NAMES:
            _write_whole(out / file_name, texts[file_name])
            written.append(out / file_name)
        if out.resolve().is_relative_to(run.resolve()):
            _add_to_manifest(run.resolve(), [path.resolve() for path in written])
    except OSError as error:
        raise ScenarioFileError(
            f"{_q(error.filename or out)}: cannot write: {error.strerror}"
        ) from None
    return written

"""Paper 003's campaigns beside the paper, for `rpod report`: Case Studies 1-2 and modulation.

Owns: `campaign_rows` (the plug-in's `campaign_table`), `metric_rows` (the ok runs' metrics of
a planar campaign, which the campaign maps read too) and UNRECORDED (the formulation of a
stored run that did not record one).
Does not own: the maps (campaign_maps.py), the success share's statistics
(rpod.models.statistics) or the report's formatting (rpod.scenarios.report).
"""

import itertools

import numpy as np

from rpod.models.statistics import SuccessShare

UNRECORDED = "not recorded (runs stored before rpod recorded it)"
"""The formulation of a stored run without `planar_formulation`."""


def metric_rows(rows: list[dict]) -> list[dict]:
    """The metrics of the ok runs that are this plug-in's."""
    return [
        row["metrics"]
        for row in rows
        if row.get("status") == "ok"
        and row.get("metrics")
        and "planar_plan_status" in row["metrics"]
    ]


def _mean_std(values) -> str:
    """'mean +- std' of the values given (None left out), or the one value, or '-'."""
    values = np.array([v for v in values if v is not None], float)
    if not values.size:
        return "-"
    if values.size == 1:
        return f"{values[0]:.4g}"
    return f"{values.mean():.4g} +- {values.std():.2g}"


def _share(flags) -> str:
    flags = list(flags)
    return f"{100.0 * sum(flags) / len(flags):.0f}% ({sum(flags)}/{len(flags)})" if flags else "-"


def campaign_rows(rows: list[dict]) -> tuple[str, list[str], list[list[str]]] | None:
    """The `rpod report` table of a planar-approach campaign (rows of the store), or None.

    The title leads with the mission success share of the ok runs (Wilson 95 %), then the
    safety figures (planned to the goal and no contact in the whole run; contact), and names
    the formulation each run recorded (`planar_formulation`); with several, the lines are
    grouped by formulation, labelled A, B, ... in a first column.
    Varying modulation: one line per scheme (tracking error, terminal speed, fuel, switches).
    Else varying theta_approach (Case Study 2, Fig. 9): one line per theta; else varying
    omega_target (Case Study 1, Fig. 8): one line per omega. Each line: runs, planned
    (success), planned terminal error (the paper's "final position error", mean +- std over the
    other parameter), flown RMS tracking error, safe share (planned and no contact), mission.
    """
    metrics = metric_rows(rows)
    if not metrics:
        return None
    mission = SuccessShare(
        sum((m.get("mission") or {}).get("success") is True for m in metrics), len(metrics)
    )
    safe_share = SuccessShare(sum(bool(m.get("planar_safe")) for m in metrics), len(metrics))
    contact_share = SuccessShare(sum(bool(m.get("planar_contact")) for m in metrics), len(metrics))
    formulations = sorted({m.get("planar_formulation") or UNRECORDED for m in metrics})
    labels = {text: chr(ord("A") + i) for i, text in enumerate(formulations)}
    if len(formulations) == 1:
        named = f"Formulation: {formulations[0]}"
    else:  # one group of lines per formulation, labelled
        named = "Formulations: " + "; ".join(f"{labels[f]}: {f}" for f in formulations)
    lead = (
        f"mission success {mission.percent_text()} of the ok runs; safe (plan reached its goal, "
        f"no contact in the whole run) {safe_share.percent_text()}; contact "
        f"{contact_share.percent_text()}. {named}"
    )
    schemes = sorted({m["planar_modulation"] for m in metrics})
    if len(schemes) > 1:
        header = ["modulation", "runs", "RMS tracking cm", "terminal m/s", "delta-v m/s"]
        header += ["switches", "contact", "mission"]
        table = []
        for scheme in schemes:
            group = [m for m in metrics if m["planar_modulation"] == scheme]
            table.append(
                [
                    scheme,
                    str(len(group)),
                    _mean_std(
                        [
                            100.0 * m["planar_rms_tracking_error_m"]
                            if m["planar_rms_tracking_error_m"] is not None
                            else None
                            for m in group
                        ]
                    ),
                    _mean_std([m["planar_terminal_relative_speed_m_s"] for m in group]),
                    _mean_std([m["planar_delta_v_m_s"] for m in group]),
                    _mean_std([m["planar_switches"] for m in group]),
                    _share([m["planar_contact"] for m in group]),
                    _share([(m.get("mission") or {}).get("success") is True for m in group]),
                ]
            )
        title = (
            f"Paper 003's approach flown with each modulation scheme (beyond the paper): {lead}:"
        )
        return title, header, table
    thetas = sorted({round(m["planar_theta_approach_deg"], 6) for m in metrics})
    key, label = (
        ("planar_theta_approach_deg", "theta_approach deg")
        if len(thetas) > 1
        else ("planar_omega_target_rad_s", "omega_target rad/s")
    )
    values = sorted({round(m[key], 6) for m in metrics})
    header = [label, "runs", "mission", "safe", "planned to the goal"]
    header += ["planned final error m (mean +- std)", "flown RMS tracking m"]
    several = len(formulations) > 1
    table = []
    for formulation, value in itertools.product(formulations, values):
        group = [
            m
            for m in metrics
            if round(m[key], 6) == value
            and (m.get("planar_formulation") or UNRECORDED) == formulation
        ]
        if not group:
            continue
        table.append(
            [labels[formulation]] * several
            + [
                f"{value:g}",
                str(len(group)),
                _share([(m.get("mission") or {}).get("success") is True for m in group]),
                _share([m["planar_safe"] for m in group]),
                _share([m["planar_plan_success"] for m in group]),
                _mean_std([m["planar_plan_terminal_position_error_m"] for m in group]),
                _mean_std([m["planar_rms_tracking_error_m"] for m in group]),
            ]
        )
    case = "2 (Fig. 9)" if len(thetas) > 1 else "1 (Fig. 8)"
    title = f"Paper 003 Case Study {case} beside this campaign: {lead}:"
    return title, ["formulation"] * several + header, table

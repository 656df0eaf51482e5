"""`rig noise DIR`: the Allan deviation of a still recording and the noise terms it determines, per sensor and axis.

What a long still log (an Allan-variance run: hours of a unit left still) is recorded for. No calibration is
needed or made: the streams are taken in the units they were recorded in (counts, or the SI unit of an imported
column), so one pose is enough where `rig calibrate` and `rig discrepancy` need many. The stretch read is the
whole recording, a part of it (`--start`, `--end`) or its longest still stretch (`--window still`); a warm-up at
its start is named (`warm_up`, effects.md) and each sensor is analysed from where it has settled, unless
`--keep-warm-up`. A term the record is too short for is said not determinable, with the bound the record gives
(`rig.noise.terms`). Samples a sensor lacks are left out of its streams.
"""

from __future__ import annotations

import json
from pathlib import Path

import click

from rig.exits import CommandError, Exit, FiniteFloat, command_error

TERMS = (("Q", "quantisation noise", "s"), ("N", "white noise", "per sqrt(Hz)"), ("B", "bias instability", ""),
         ("K", "rate random walk", "sqrt(Hz)"))


@click.command()
@click.argument("session_dir", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option("--start", "start_s", type=FiniteFloat(0), default=None, metavar="S",
              help="Analyse from S seconds after the recording's start.")
@click.option("--end", "end_s", type=FiniteFloat(0, low_open=True), default=None, metavar="S",
              help="Analyse up to S seconds after the recording's start.")
@click.option("--window", type=click.Choice(["record", "still"]), default="record", show_default=True,
              help="record: the whole recording (or --start/--end); still: its longest still stretch within them.")
@click.option("--keep-warm-up", is_flag=True,
              help="Analyse from the stretch's start even where a warm-up is found (by default each sensor is "
                   "analysed from where it has settled).")
@click.option("--json", "json_out", type=click.Path(dir_okay=False, path_type=Path),
              help="Also write the curves, the terms and what was analysed as JSON.")
def noise(session_dir, start_s, end_s, window, keep_warm_up, json_out):
    """The Allan deviation of a static recording and its noise terms, per sensor and axis.

    White noise, bias instability, rate random walk and quantisation noise (IEEE 952), in the units the recording
    holds; no calibration is needed. A term the record is too short to determine is said so. A warm-up at the
    start is named and, unless --keep-warm-up, left out of the analysis."""
    from fixtures.world.effects.warm_up import WarmUp
    from rig.commands.common import read_any_session
    from rig.errors import RigError
    from rig.io.atomic import write_text_atomic
    from rig.noise.analysis import analyse_still

    try:
        session = read_any_session(session_dir)
        report = analyse_still(session, start_s=start_s, end_s=end_s, window=window, skip_warm_up=not keep_warm_up)
    except RigError as exc:
        raise command_error(exc) from None
    report["effects"] = warm_ups(report, WarmUp.name)
    for line in summary(report, WarmUp.name):
        click.echo(line)
    if json_out is not None:
        try:
            json_out.parent.mkdir(parents=True, exist_ok=True)
            write_text_atomic(json_out, json.dumps(report, indent=2) + "\n")
        except OSError as exc:
            raise CommandError(f"{json_out}: cannot write the report: {exc.strerror}", Exit.BAD_INPUT) from None
        click.echo(f"wrote {json_out}")


def warm_ups(report: dict, name: str) -> list[dict]:
    """Each warm-up found, as an effect of the vocabulary: its `a` (the recording's unit) and `tau` (s)."""
    out = []
    for sensor, axes in report["sensors"].items():
        for axis, fit in axes.items():
            trend = fit["start_trend"]
            if trend is not None:
                out.append({"effect": name, "sensor": sensor, "axis": axis, "magnitude": abs(trend["a"]),
                            "unit": report["units"][sensor], "params": trend})
    return out


def _value(value: float, std: float | None = None) -> str:
    return f"{value:.4g}" + (f" +/- {std:.2g}" if std is not None else "")


def summary(report: dict, name: str) -> list[str]:
    """The lines `rig noise` prints: what was analysed, each warm-up, and each axis's terms."""
    analysed = report["analysed"]
    lines = [f"analysed: {analysed['what']}, {analysed['start_s']:.1f}-{analysed['end_s']:.1f} s of the "
             f"recording's {report['seconds']:.1f} s"]
    for sensor, span in report["spans"].items():
        if span["after_warm_up"]:
            lines.append(f"  {sensor}: from {span['start_s']:.1f} s, after its warm-up (--keep-warm-up analyses it "
                         "too)")
    for found in report["effects"]:
        p = found["params"]
        kept = "" if analysed["skip_warm_up"] else "; analysed with it, its drift in the terms"
        lines.append(f"{found['sensor']}.{found['axis']}: warm-up ({name}): a = {_value(p['a'], p['a_std'])} "
                     f"{found['unit']}, tau = {_value(p['tau_s'], p['tau_s_std'])} s ({p['shape']}){kept}")
    for sensor, axes in report["sensors"].items():
        unit = report["units"][sensor]
        for axis, fit in axes.items():
            lines.append(f"{sensor}.{axis}: {axis_line(fit, unit)} (tau {fit['tau_s'][0]:g}-{fit['tau_s'][-1]:g} s)")
    return lines


def axis_line(fit: dict, unit: str) -> str:
    """'white noise 0.2 +/- 0.001 counts per sqrt(Hz); bias instability not determinable from 60 s (below ...)'."""
    fitted, unknown, absent = [], [], []
    for key, term_name, per in TERMS:
        term = fit["terms"][key]
        full_unit = f"{unit}{' ' + per if per else ''}"
        if term["status"] == "fitted":
            fitted.append(f"{term_name} {_value(term['value'], term['std'])} {full_unit}")
        elif term["status"] == "not determinable":
            unknown.append((term_name, f"{term['bound']:.2g} {full_unit}"))
        else:
            absent.append((term_name, f"{term['bound']:.2g} {full_unit}"))
    parts = list(fitted)
    if unknown:
        parts.append(f"{' and '.join(n for n, _ in unknown)} not determinable from {fit['record_s']:.4g} s (below "
                     f"{', '.join(b for _, b in unknown)})")
    for term_name, bound in absent:
        parts.append(f"no {term_name} (below {bound})")
    return "; ".join(parts)

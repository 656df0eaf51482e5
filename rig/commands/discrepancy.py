"""`rig discrepancy SESSION_DIR --json OUT.json [--report DIR]`: what the linear model misses in a
measured session (the rig's own folder or an interchange one), named in the `effects.md` vocabulary.

A sensor the analysis could not test is said on the terminal, in the JSON (`skipped`, `not_analysed`) and in
the report's summary, and the exit code is 1: "nothing missing" is only claimed of what was analysed.

A recording without a turntable (no reference orientations) is compared with its simulated twin instead
(procedures.twin.analysis): every statistic against the replicas' band, the noise and recording effects that
explain what falls outside, and what stays unexplained (`twin` in the JSON, plots in the report folder).
"""

from __future__ import annotations

import json
import sys
import warnings
from pathlib import Path

import click

from rig.exits import CommandError, Exit, command_error, plain, stop_signals_raise

SENSORS = ("accel", "gyro", "mag")


@click.command()
@click.argument("session_dir", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option("--json", "json_out", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="Where to write the rig-discrepancy/1 report.")
@click.option("--report", "report_dir", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Folder for the residual-vs-covariate plots (before / after each finding) and a summary.")
@click.option("--no-replay", is_flag=True, help="Skip replaying the schedule in the simulator.")
@click.option("--replicas", type=click.IntRange(10, 1000), default=None,
              help="Replicas of a recording's twin (recordings without a turntable); default 99, whose extremes are "
              "the 1-99 % band, fewer for a long recording (down to 40) to stay within about 30 s.")
@click.option("--heldout", is_flag=True,
              help="Recordings: also score the held-out predictions before and after the named model effects are "
                   "taken into the calibration (slower: every piece left out and refitted twice).")
def discrepancy(session_dir, json_out, report_dir, no_replay, replicas, heldout):
    """Fit the linear model, test every candidate effect, report the ones the data support."""
    from procedures.replay import replay_comparison
    from rig.commands.common import read_any_session, session_kind
    from rig.discrepancy import analyze
    from rig.errors import RigError
    from rig.io.atomic import write_text_atomic
    from rig.recording_kinds import refuse_unless_taken

    try:
        kind = session_kind(session_dir)
        if kind is not None:
            refuse_unless_taken("discrepancy", *kind, session_dir)
        session = read_any_session(session_dir)
    except RigError as exc:
        raise command_error(exc) from None
    session.meta.setdefault("session", session_dir.name)
    if session.meta.get("reference") == "none":
        return _recording(session, session_dir, json_out, report_dir, replicas, heldout)
    try:
        with warnings.catch_warnings():       # overflow on absurd data is reported below, not as numpy noise
            warnings.simplefilter("ignore", RuntimeWarning)
            report = analyze(session, replay=None if no_replay else replay_comparison, plots_dir=report_dir)
    except RigError as exc:
        raise command_error(exc, prefix=f"{session_dir}: ") from None
    except (ValueError, ArithmeticError) as exc:      # numpy's LinAlgError is a ValueError
        raise CommandError(f"{session_dir}: the analysis cannot run on these data ({type(exc).__name__}: "
                           f"{plain(str(exc))}); check the session for extreme or non-finite values") from None
    analysed = sorted(report.get("baseline", {}))
    present = [s for s in SENSORS if s in session.raw]
    not_analysed = [s for s in present if s not in analysed]
    report["not_analysed"] = not_analysed
    try:
        json_out.parent.mkdir(parents=True, exist_ok=True)
        write_text_atomic(json_out, json.dumps(report, indent=2, default=_plain) + "\n")
        if report_dir is not None:
            Path(report_dir).mkdir(parents=True, exist_ok=True)
            write_text_atomic(Path(report_dir) / "summary.md", summary_markdown(report, analysed, not_analysed))
    except OSError as exc:
        raise CommandError(f"{exc.filename or json_out}: cannot write the report: {exc.strerror}") from None
    for reason in report.get("skipped", []):
        click.echo(f"warning: not tested: {plain(reason)}", err=True)
    if not report["findings"]:
        if not analysed:
            click.echo("no sensor could be analysed; nothing is claimed about the data")
        else:
            click.echo(f"no missing effect found in {', '.join(analysed)}: the linear model explains "
                       f"{'them' if len(analysed) > 1 else 'it'} to within noise")
    for f in report["findings"]:
        amb = f" (ambiguous with {', '.join(f['ambiguous_with'])})" if f.get("ambiguous_with") else ""
        click.echo(f"{f['effect']} on {f['sensor']}: {f['magnitude']:.4g} +- {f['uncertainty']:.2g} {f['unit']}; "
                   f"held-out RMS {f['heldout_rms_before']:.3g} -> {f['heldout_rms_after']:.3g} {f['heldout_unit']}{amb}")
    if not_analysed:
        click.echo(f"NOT analysed: {', '.join(not_analysed)} (see the warnings above); the result covers "
                   f"{', '.join(analysed) or 'no sensor'} only", err=True)
    click.echo(f"wrote {json_out}")
    if not_analysed:
        sys.exit(Exit.FAIL)


def _recording(session, session_dir: Path, json_out: Path, report_dir: Path | None, replicas: int | None,
               heldout: bool = False) -> None:
    """A recording without a turntable against its twin: named causes as findings, the rest unexplained."""
    from procedures.twin.analysis import analyse_twin
    from procedures.twin.gyroless import analyse_gyroless_twin
    from procedures.twin.model import NothingCalibrated
    from rig.errors import RigError
    from rig.io.atomic import write_text_atomic

    if heldout and "gyro" not in session.raw:
        click.echo("warning: --heldout: the held-out scores are the gyroscope's, and the recording has none",
                   err=True)
    try:
        # a stop signal raised here, not the default death: the replicas' pools are ended on the way out, not
        # left to finish into a closed pipe
        with warnings.catch_warnings(), stop_signals_raise():
            warnings.simplefilter("ignore", RuntimeWarning)
            twin = (analyse_twin(session, replicas=replicas, heldout=heldout) if "gyro" in session.raw
                    else analyse_gyroless_twin(session, replicas=replicas))
    except NothingCalibrated as exc:
        click.echo(f"NOT analysed: {plain(str(exc))}; nothing is claimed about the data", err=True)
        sys.exit(Exit.FAIL)
    except RigError as exc:
        raise command_error(exc, prefix=f"{session_dir}: ") from None
    except (ValueError, ArithmeticError) as exc:
        raise CommandError(f"{session_dir}: the twin cannot be built from these data ({type(exc).__name__}: "
                           f"{plain(str(exc))})") from None
    tested = {(t["effect"], t["sensor"]): t for t in twin["model_tests"]}
    findings = [{"effect": c["effect"], "sensor": c["sensor"], "magnitude": c["magnitude"], "unit": c["unit"],
                 "uncertainty": tested.get((c["effect"], c["sensor"]), {}).get("uncertainty"), "heldout_rms_before": None, "heldout_rms_after": None, "heldout_unit": None,
                 "evidence": {"params": c["params"], "statistics_brought_back": c["brings_back"],
                              "statistics_pushed_out": c["pushes_out"]}}
                for c in twin["causes"] if c["brings_back"]]
    summary = twin["summary"]
    report = {"schema": "rig-discrepancy/1", "session": str(session.meta.get("session", session.source)),
              "findings": findings,
              "candidates": [{"effect": c["effect"], "sensor": c["sensor"], "score": float(len(c["brings_back"])),
                              "pushed_out": len(c["pushes_out"]), "kept": kept,
                              "significant": bool(kept and c["brings_back"]),
                              "statistics_brought_back": c["brings_back"], "statistics_pushed_out": c["pushes_out"]}
                             for kept, group in ((True, twin["causes"]), (False, twin.get("dropped", [])))
                             for c in group],
              "unexplained": twin["unexplained"], "not_analysed": sorted(twin["not_analysed"]), "twin": twin}
    files = []
    try:
        json_out.parent.mkdir(parents=True, exist_ok=True)
        write_text_atomic(json_out, json.dumps(report, indent=2, default=_plain) + "\n")
        if report_dir is not None:
            from rig.report.twin_plots import write_twin_plots

            files = write_twin_plots(twin, report_dir)
            write_text_atomic(Path(report_dir) / "summary.md", twin_markdown(report, files))
    except OSError as exc:
        raise CommandError(f"{exc.filename or json_out}: cannot write the report: {exc.strerror}") from None
    n = summary["statistics"]
    click.echo(f"{session_dir}: a recording without a turntable, {twin['replayed']}, against its twin "
               f"({twin['replicas']} replicas)")
    click.echo(f"statistics inside the replicas' 1-99 % band: {summary['inside_before']}/{n} "
               f"({100 * summary['inside_before'] / n:.0f} %) with the simulator's white noise, "
               f"{summary['inside_after']}/{n} ({100 * summary['inside_after'] / n:.0f} %) with what the recording shows")
    for t in twin["model_tests"]:
        click.echo(f"model test {t['effect']} on {t['sensor']}: {t['magnitude']:.4g} +/- {t['uncertainty']:.2g} {t['unit']}, "
                   f"p {t['p_holm']:.2g} after Holm: {'significant' if t['significant'] else 'not significant'}")
    for c in twin["causes"]:
        back, out = len(c["brings_back"]), len(c["pushes_out"])
        click.echo(f"{c['effect']} on {c['sensor']}: {c['magnitude']:.4g} {c['unit']}; brings back {back} "
                   f"statistic{'s' if back != 1 else ''}" + (f", pushes {out} out" if out else ""))
    for c in twin.get("dropped", []):
        click.echo(f"not kept: {c['effect']} on {c['sensor']} ({c['magnitude']:.4g} {c['unit']}): brought back "
                   f"{len(c['brings_back'])}, pushed out {len(c['pushes_out'])}")
    change = twin.get("heldout_change")
    if change:
        b, a = change["before"], change["after"]
        for key, what in (("gyro_carry_deg", "gravity carried across a left-out motion"),
                          ("gyro_rest_carry_deg", "gravity carried into and out of the rests no segment names"),
                          ("gyro_turn_deg", "a left-out turn")):
            if b[key]["rms"] is not None and a[key]["rms"] is not None:
                click.echo(f"held out, {what}: {b[key]['rms']:.3f} deg RMS before, {a[key]['rms']:.3f} deg with "
                           f"{', '.join(change['causes'])} in the calibration")
    if twin["unexplained"]:
        click.echo(f"unexplained: {len(twin['unexplained'])} statistics stay outside the band (listed in {json_out})")
    click.echo(f"wrote {json_out}" + (f" and {len(files)} plots in {report_dir}" if files else ""))
    for sensor, why in twin["not_analysed"].items():
        click.echo(f"NOT analysed: {sensor}: {plain(why)}; the twin replays the poses alone, without the motions "
                   f"between them, and the result covers {', '.join(twin['calibration'])} only", err=True)
    if twin["not_analysed"]:
        sys.exit(Exit.FAIL)


def twin_markdown(report: dict, files: list[Path]) -> str:
    twin = report["twin"]
    s = twin["summary"]
    n = s["statistics"]
    lines = [f"# {report['session']} against its simulated twin", "",
             f"{twin['replicas']} replicas: the recording ({twin['replayed']}) replayed in the simulated world with "
             "its own calibration and noise; a statistic outside the replicas' 1-99 % band is something the simulation "
             "gets wrong.", "",
             "| | inside the band |", "| --- | --- |",
             f"| the simulator's white noise | {s['inside_before']}/{n} ({100 * s['inside_before'] / n:.0f} %) |",
             f"| extended with what the recording shows | {s['inside_after']}/{n} ({100 * s['inside_after'] / n:.0f} %) |",
             "", "## Named causes", "",
             "A cause is kept where it brings more statistics back inside their band than it pushes out of it.", "",
             "| effect | sensor | magnitude | statistics brought back | statistics pushed out |",
             "| --- | --- | --- | --- | --- |"]
    lines += [f"| {c['effect']} | {c['sensor']} | {c['magnitude']:.4g} {c['unit']} | {len(c['brings_back'])} | "
              f"{len(c['pushes_out'])} |" for c in twin["causes"]] or ["| none | | | | |"]
    dropped = twin.get("dropped", [])
    if dropped:
        lines += ["", "## Not kept", "", "| effect | sensor | magnitude | statistics brought back | statistics pushed out |",
                  "| --- | --- | --- | --- | --- |"]
        lines += [f"| {c['effect']} | {c['sensor']} | {c['magnitude']:.4g} {c['unit']} | {len(c['brings_back'])} | "
                  f"{len(c['pushes_out'])} |" for c in dropped]
    for kept, group in ((" (kept)", twin["causes"]), (" (not kept)", dropped)):
        for c in group:
            lines += ["", f"### {c['effect']} on {c['sensor']}{kept}", "",
                      "Brought back inside: " + (", ".join(f"`{n}`" for n in c["brings_back"]) or "none") + ".", "",
                      "Pushed out: " + (", ".join(f"`{n}`" for n in c["pushes_out"]) or "none") + "."]
    for sensor, why in twin["not_analysed"].items():
        lines += ["", f"**Not analysed: {sensor}**: {plain(why)}; nothing is claimed about it, and the twin replays "
                  "the poses alone."]
    lines += ["", f"## Unexplained ({len(twin['unexplained'])})", ""]
    lines += [f"- {name}" for name in twin["unexplained"]] or ["- none"]
    lines += ["", "## Plots", ""] + [f"![{f.stem}]({f.name})" for f in files]
    return "\n".join(lines) + "\n"


def summary_markdown(report: dict, analysed: list[str], not_analysed: list[str]) -> str:
    lines = [f"# Discrepancy analysis of {report.get('session', '')}", "",
             f"Analysed: {', '.join(analysed) or 'none'}."]
    if not_analysed:
        lines.append(f"**Not analysed: {', '.join(not_analysed)}** (see below); nothing is claimed about "
                     f"{'them' if len(not_analysed) > 1 else 'it'}.")
    lines += ["", "## Findings", ""]
    lines += [f"- {f['effect']} on {f['sensor']}: {f['magnitude']:.4g} +- {f['uncertainty']:.2g} {f['unit']}"
              for f in report["findings"]] or ["- none in the analysed sensors"]
    if report.get("skipped"):
        lines += ["", "## Not tested", ""] + [f"- {plain(s)}" for s in report["skipped"]]
    return "\n".join(lines) + "\n"


def _plain(x):
    import numpy as np

    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    raise TypeError(f"not JSON serialisable: {type(x).__name__}")

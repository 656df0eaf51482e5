"""`rig noise DIR`: the Allan deviation of a static recording and the noise terms it shows, per sensor and axis.

What a long static log (an Allan-variance run: hours of a unit left still) is recorded for. No calibration is
needed or made: the streams are taken in the units they were recorded in (counts, or the SI unit of an imported
column), so one pose is enough where `rig calibrate` and `rig discrepancy` need many. The whole recording is one
stretch; samples a sensor lacks are left out of its streams.
"""

from __future__ import annotations

import json
from pathlib import Path

import click

from rig.exits import CommandError, Exit, command_error

TERMS = (("N", "white noise", "per sqrt(Hz)"), ("B", "bias instability", ""), ("K", "rate random walk", "sqrt(Hz)"),
         ("Q", "quantisation noise", "s"))


@click.command()
@click.argument("session_dir", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option("--json", "json_out", type=click.Path(dir_okay=False, path_type=Path),
              help="Also write the curves and the fitted terms as JSON.")
def noise(session_dir, json_out):
    """The Allan deviation of a static recording and its noise terms, per sensor and axis.

    White noise, bias instability, rate random walk and quantisation noise (IEEE 952), in the units the recording
    holds; no calibration is needed."""
    from rig.commands.sessions import read_any_session
    from rig.errors import RigError
    from rig.io.atomic import write_text_atomic

    try:
        session = read_any_session(session_dir)
    except RigError as exc:
        raise command_error(exc) from None
    report = static_noise(session)
    for sensor, axes in report["sensors"].items():
        unit = report["units"][sensor]
        for axis, fit in axes.items():
            terms = ", ".join(f"{name} {fit[key]:.4g} +/- {fit[key + '_std']:.2g} {unit}{' ' + per if per else ''}"
                              for key, name, per in TERMS if fit[key] > 0)
            click.echo(f"{sensor}.{axis}: {terms or 'no term fitted'} (tau {fit['tau_s'][0]:g}-{fit['tau_s'][-1]:g} s)")
    if json_out is not None:
        try:
            json_out.parent.mkdir(parents=True, exist_ok=True)
            write_text_atomic(json_out, json.dumps(report, indent=2) + "\n")
        except OSError as exc:
            raise CommandError(f"{json_out}: cannot write the report: {exc.strerror}", Exit.BAD_INPUT) from None
        click.echo(f"wrote {json_out}")


def static_noise(session) -> dict:
    """Per sensor and axis: the overlapping Allan deviation (octave taus up to a third of the stream) and the
    IEEE 952 terms fitted to it (`rig.noise.allan`)."""
    import numpy as np

    from rig.noise.allan import allan_deviation, fit_noise
    from rig.noise.still import STILL_RATIO, stillness_ratio

    rate = float(session.sample_rate_hz or 1.0 / np.median(np.diff(session.t)))
    units = session.meta.get("units", {})
    out = {"schema": "rig-noise/1", "session": str(session.source), "rate_hz": rate, "rows": int(len(session.t)),
           "seconds": float(session.t[-1] - session.t[0]) if len(session.t) else 0.0,
           "units": {s: units.get(s, "counts") for s in session.raw}, "sensors": {}}
    for sensor, y in session.raw.items():
        axes = {}
        for k, axis in enumerate("xyz"):
            stream = y[:, k]
            try:
                curve = allan_deviation(stream, rate)
            except ValueError as exc:
                raise CommandError(f"{session.source}: {sensor}.{axis}: {exc}", Exit.BAD_INPUT) from None
            ratio = stillness_ratio(stream)
            if ratio > STILL_RATIO:
                raise CommandError(f"{session.source}: {sensor}.{axis} is not still: its spread is "
                                   f"{ratio:.0f} times its sample-to-sample noise; `rig noise` "
                                   "reads a static recording (one pose held), and the Allan deviation of a moving "
                                   "one says nothing about its noise", Exit.BAD_INPUT)
            terms = fit_noise(curve)
            axes[axis] = {"tau_s": curve.tau.tolist(), "adev": curve.adev.tolist(), "adev_err": curve.err.tolist(),
                          "samples": int(np.isfinite(stream).sum()),
                          **{key: getattr(terms, key) for key in "NBKQ"},
                          **{f"{key}_std": terms.std[key] for key in "NBKQ"}}
        out["sensors"][sensor] = axes
    return out

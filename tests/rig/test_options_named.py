"""Every option a message names exists on the command line that shows it.

The strings each command of `rig` can show (its refusals, warnings, help; `command_reach`: a static call graph from
its callback) are read for `--option` names; each must be an option of that command, or of the command the string
names ("`rig import ... --initial-rest-s S`"). A shared message once advised `--units` to `rig import imu_tk`, which
did not have it. The call graph reaches more than a command shows; what it reaches that the command can never
show, for a reason of data, is listed below with that reason, and so is what remains to be fixed in a file of
another owner. The lists must match what is found: a fix takes its entry out.
"""

from __future__ import annotations

import sys
import textwrap
import types
from pathlib import Path

import click

sys.path.insert(0, str(Path(__file__).resolve().parent))
from command_reach import Source, command_tree, options_not_taken  # noqa: E402

from rig.cli import main  # noqa: E402

# (command, module of the string, option) -> why that command never shows the string
NEVER_SHOWN = {
    ("batch", "rig.pipeline.run", "--settle-s"): "holds shorter than the settling time: a batch calibrates with "
                                                 "settle_s 0 (rig.lab.batch), which no hold is shorter than",
    ("repeatability", "rig.pipeline.run", "--settle-s"): "the orchestrator calibrates with settle_s 0",
    ("resume", "rig.pipeline.run", "--settle-s"): "the orchestrator calibrates with settle_s 0",
    ("validate", "rig.pipeline.run", "--settle-s"): "the orchestrator calibrates with settle_s 0",
    ("repeatability", "rig.assembly", "--time-scale"): "repeatability runs every trial with time_scale None",
    ("validate", "rig.assembly", "--time-scale"): "validate builds its rig with no time scale",
    ("resume", "rig.assembly", "--time-scale"): "a resumed session keeps the time scale and the all-simulated rig "
                                                "it was started with",
    ("resume", "procedures.orchestrator", "--out"): "an existing session is refused when one starts "
                                                    "(SessionOrchestrator.start), never on resume",
    ("resume", "procedures.thermal_session", "--out"): "an existing thermal session is refused when one starts "
                                                       "(ThermalSession.start), never on resume",
    ("resume", "rig.planner", "--target-h-pct"): "a thermal session's steps say the planner's refusal with the "
                                                 "option's place taken by [thermal] step_H_std_pct (step_plan)",
    ("resume", "rig.assembly", "--sim"): "slots mixing real and emulated parts are refused when the session "
                                         "starts; a resumed one rebuilds the rig it was started with",
}

# (command, module, option) -> what the command says of an option it does not take, in a file this work does not
# own (reported to its owner)
TO_FIX_ELSEWHERE = {
    ("repeatability", "rig.report.calibration_report", "--plots"): "the report says figures are drawn on demand with "
                                                                   "--plots; repeatability has none",
    ("validate", "rig.report.calibration_report", "--plots"): "the report says figures are drawn on demand with "
                                                              "--plots; validate has --no-plots only",
}


def test_every_option_a_command_can_name_is_one_it_or_the_command_named_takes():
    findings = options_not_taken(command_tree(main), Source())
    found = {f.key for f in findings}
    unexpected = [str(f) for f in findings if f.key not in NEVER_SHOWN and f.key not in TO_FIX_ELSEWHERE]
    assert not unexpected, "options named that the command does not take:\n" + "\n".join(sorted(set(unexpected)))
    stale = sorted((set(NEVER_SHOWN) | set(TO_FIX_ELSEWHERE)) - found)
    assert not stale, f"listed but no longer found (take them out of the lists): {stale}"


def test_the_importers_reach_the_shared_refusal_through_a_lambda_an_alias_and_an_import_in_a_function():
    """`rig import imu_tk` builds its session in a lambda around `build`, the name a function-level import gives
    `rig.io.import_imu_tk.import_imu_tk`; `rig calibrate --format imu_tk` goes through the pipeline. Both reach
    the refusal of a fractional count (rig.io.recording.check_counts), which names --units."""
    tree = command_tree(main)
    source = Source()
    for words in (("import", "imu_tk"), ("calibrate",), ("import", "csv")):
        said = [s for s in source.said_by(tree[words].callback) if "say so with --units" in s.text]
        assert [s.chain[-1] for s in said] == [("rig.io.recording", "check_counts")], words


def test_an_option_that_no_command_line_takes_is_found(tmp_path):
    """A throwaway command whose helper, in another module, advises an option the command does not take."""
    package = tmp_path / "rig"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "helpers.py").write_text(textwrap.dedent('''
        def refuse(value):
            raise ValueError(f"{value}: not allowed; give --missing instead, or --given")
        '''))
    (package / "throwaway.py").write_text(textwrap.dedent('''
        import click

        @click.command()
        @click.option("--given", help="Named here, and taken.")
        def throwaway(given):
            from rig.helpers import refuse as check

            run = lambda: check(given)
            run()
        '''))
    callback = types.SimpleNamespace(__module__="rig.throwaway", __qualname__="throwaway")
    tree = {("throwaway",): click.Command("throwaway", params=[click.Option(["--given"])], callback=callback)}
    findings = options_not_taken(tree, Source(tmp_path))
    assert [(f.command, f.option, f.said.module) for f in findings] == [(("throwaway",), "--missing", "rig.helpers")]

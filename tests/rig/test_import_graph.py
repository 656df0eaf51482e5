"""The project's import graph, built from the source (ast): dependencies point one way (DEVELOPERS.md).

Layers, bottom to top: drivers; the math and I/O of rig; fixtures (the simulated hardware and world); procedures;
the application (rig/cli.py, rig/commands, rig/assembly.py). No module imports a layer above its own, no two
packages import each other (drivers, fixtures, procedures and each part of rig: rig.calibration, rig.io, ...), and
no import hides inside a function outside the application, except the few lazy loads of a heavy or optional
library listed below with their reason.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("drivers", "rig", "fixtures", "procedures")
APPLICATION = ("rig.cli", "rig.commands", "rig.assembly", "rig.__main__")
LAYER_NAMES = ("drivers", "rig (math, I/O)", "fixtures", "procedures", "application")

# (module, imported module) -> why it loads when first used rather than when imported
LAZY_ALLOWED = {
    ("drivers.gpio", "gpiod"): "an optional package (the rig's own computer, pip extra 'gpio'): loaded when the line "
                               "is opened, with a message naming the extra when it is missing",
    ("drivers.buses", "spidev"): "an optional package (pip extra 'spi'): loaded when a bus is opened, with a message "
                                 "naming the extra when it is missing",
    ("rig.attitude.peers", "ahrs.filters"): "a peer's filter, loaded only when the comparison with it is asked for",
    ("rig.noise.allan", "allantools"): "start-up: allantools only when an Allan deviation is computed",
    ("rig.calibration.turntable.gyro", "filterpy.kalman"): "start-up: filterpy loads scipy.stats, about a second, "
                                                           "which only the turntable gyro's UKF uses; every "
                                                           "calibration imports the module",
    ("rig.noise.statistics", "scipy.signal"): "start-up: scipy.signal only for a spectrum",
    ("rig.quaternions", "scipy.spatial.transform"): "start-up: scipy.spatial (most of a second) only when a "
                                                     "rotation is converted; `rig import` and the lab's commands "
                                                     "read and write files without one",
    ("rig.discrepancy.plots", "matplotlib"): "start-up: matplotlib only when plots are written",
    ("rig.discrepancy.plots", "matplotlib.pyplot"): "start-up: matplotlib only when plots are written",
    ("rig.report.calibration_report", "rig.report.plots"): "session speed: the report's figures (matplotlib) only when drawn, after the result",
    ("rig.lab.plots", "matplotlib"): "start-up: matplotlib only when a history plot is drawn",
    ("rig.lab.plots", "matplotlib.dates"): "start-up: matplotlib only when a history plot is drawn",
    ("rig.lab.plots", "matplotlib.pyplot"): "start-up: matplotlib only when a history plot is drawn",
    ("rig.lab.batch", "dask.distributed"): "start-up: Dask (the lab extra) only when a batch runs",
    ("rig.lab.stores", "rig.lab.pg_store"): "psycopg's pool (the lab extra) only when a database URL is given; a "
                                            "folder store works without the extra",
    ("procedures.paper_table1", "matplotlib"): "start-up: matplotlib only when the figure is drawn",
    ("procedures.paper_table1", "matplotlib.pyplot"): "start-up: matplotlib only when the figure is drawn",
    ("procedures.paper_table2", "matplotlib"): "start-up: matplotlib only when the figure is drawn",
    ("procedures.paper_table2", "matplotlib.pyplot"): "start-up: matplotlib only when the figure is drawn",
    ("fixtures.pytest_plugin", "fixtures.turntable"): "start-up: the pytest11 plugin loads in every pytest run of "
                                                      "the environment; the Modbus server (pymodbus) only when a test "
                                                      "asks for the fake turntable",
    ("fixtures.world.effects.noise", "scipy.signal"): "start-up: scipy.signal only when a coloured noise is drawn",
    ("procedures.twin.extension", "scipy.signal"): "start-up: scipy.signal only when a recording's spectrum is fitted",
    ("procedures.twin.hold", "scipy.signal"): "start-up: scipy.signal only when a pose's tilt is measured",
}


def _modules() -> dict[str, tuple[Path, bool]]:
    out = {}
    for pkg in PACKAGES:
        for path in sorted((ROOT / pkg).rglob("*.py")):
            rel = path.relative_to(ROOT).with_suffix("")
            parts = list(rel.parts)
            is_pkg = parts[-1] == "__init__"
            if is_pkg:
                parts = parts[:-1]
            out[".".join(parts)] = (path, is_pkg)
    return out


MODULES = _modules()


def layer(module: str) -> int:
    top = module.split(".")[0]
    if top == "drivers":
        return 0
    if top == "fixtures":
        return 2
    if top == "procedures":
        return 3
    if any(module == a or module.startswith(a + ".") for a in APPLICATION):
        return 4
    return 1


def package(module: str) -> str:
    parts = module.split(".")
    return ".".join(parts[:2]) if parts[0] == "rig" and len(parts) > 1 else parts[0]


class _Imports(ast.NodeVisitor):
    """Every import of a module with the function it sits in (None at module level)."""

    def __init__(self, module: str, is_pkg: bool) -> None:
        self.module, self.is_pkg = module, is_pkg
        self.found: list[tuple[str, int, str | None]] = []     # (imported module, line, enclosing function)
        self._function: list[str] = []

    def _scope(self, node):
        self._function.append(node.name)
        self.generic_visit(node)
        self._function.pop()

    visit_FunctionDef = visit_AsyncFunctionDef = _scope

    def _add(self, target: str, node) -> None:
        self.found.append((target, node.lineno, self._function[-1] if self._function else None))

    def visit_Import(self, node):
        for alias in node.names:
            self._add(alias.name, node)

    def visit_ImportFrom(self, node):
        if node.level:
            base = self.module.split(".")
            base = base[: len(base) - node.level + (1 if self.is_pkg else 0)]
            source = ".".join(base + ([node.module] if node.module else []))
        else:
            source = node.module or ""
        for alias in node.names:
            sub = f"{source}.{alias.name}"
            self._add(sub if sub in MODULES else source, node)


def _imports() -> list[tuple[str, str, int, str | None]]:
    """(importer, imported, line, function) for every import in the project's packages."""
    out = []
    for module, (path, is_pkg) in MODULES.items():
        visitor = _Imports(module, is_pkg)
        visitor.visit(ast.parse(path.read_text(), str(path)))
        out += [(module, target, line, fn) for target, line, fn in visitor.found]
    return out


IMPORTS = _imports()


def _project(target: str) -> str | None:
    """The project module an import names (its longest known prefix), or None for a library."""
    parts = target.split(".")
    for k in range(len(parts), 0, -1):
        name = ".".join(parts[:k])
        if name in MODULES:
            return name
    return None


def test_the_graph_is_built_from_the_whole_source():
    assert len(MODULES) > 100 and {"rig.cli", "procedures.session", "fixtures.simrig", "drivers.buses"} <= set(MODULES)
    edges = {(a, _project(b)) for a, b, _, _ in IMPORTS if _project(b)}
    assert ("rig.discrepancy.analysis", "rig.discrepancy.candidates") in edges
    assert ("fixtures.world.draw", "rig.schedule") in edges


def test_no_module_imports_a_layer_above_its_own():
    upward = []
    for importer, target, line, _ in IMPORTS:
        dst = _project(target)
        if dst is not None and layer(dst) > layer(importer):
            upward.append(f"{MODULES[importer][0].relative_to(ROOT)}:{line}: {importer} ({LAYER_NAMES[layer(importer)]}) "
                          f"imports {dst} ({LAYER_NAMES[layer(dst)]})")
    assert not upward, "\n".join(upward)


def _strongly_connected(edges: dict[str, set[str]]) -> list[list[str]]:
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(edges.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return out


def test_no_loop_between_packages():
    edges: dict[str, set[str]] = {}
    for importer, target, _, _ in IMPORTS:
        dst = _project(target)
        if dst is not None and package(dst) != package(importer):
            edges.setdefault(package(importer), set()).add(package(dst))
    loops = _strongly_connected(edges)
    assert not loops, "package loops: " + "; ".join(" <-> ".join(c) for c in loops)


def test_the_visitor_sees_an_import_inside_a_function_and_resolves_relative_ones():
    visitor = _Imports("rig.discrepancy.analysis", False)
    source = "import numpy\nfrom . import plots\ndef f():\n    from ..calibration.turntable import joint\n"
    visitor.visit(ast.parse(source))
    assert visitor.found == [("numpy", 1, None), ("rig.discrepancy.plots", 2, None),
                             ("rig.calibration.turntable.joint", 4, "f")]
    assert layer("rig.commands.calibrate") > layer("procedures.session") > layer("fixtures.simrig") > layer("rig.units")


def test_the_loop_finder_finds_a_loop():
    assert _strongly_connected({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_no_import_hides_in_a_function_outside_the_application():
    hidden, used = [], set()
    for importer, target, line, fn in IMPORTS:
        if fn is None or layer(importer) == 4:
            continue
        if (importer, target) in LAZY_ALLOWED:
            used.add((importer, target))
            continue
        hidden.append(f"{MODULES[importer][0].relative_to(ROOT)}:{line}: import of {target} inside {fn}()")
    assert not hidden, "\n".join(hidden)
    assert not set(LAZY_ALLOWED) - used, f"listed but no longer lazy: {sorted(set(LAZY_ALLOWED) - used)}"

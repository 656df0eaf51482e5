"""The registry of chips: one entry per part a board may place, keyed by the part's `chip` name.

A board (`rig.boards`) names chips from here; the real and the simulated rig build them through their
`attach` class method; the simulated rig finds each chip's emulator in `fixtures.chips.registry`.

Each driver module declares its own part classes with `@chip_driver` (`drivers.contract`), and importing this
module imports every module of the `drivers` package (`discover`), so a new chip is its driver module alone:
no list to extend here. Modules that hold no chip (buses, errors, units, ...) are imported too, harmlessly; only
decorated classes register.
"""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Iterable

import drivers
from drivers.contract import REGISTERED, Part


def discover(package: str = "drivers", path: Iterable[str] | None = None) -> list[str]:
    """Import every module of `package` (its `__path__`, names not starting with "_"), in name order; return the
    names. This loader imports the package's own modules by name (importlib) as its whole job: the driver modules
    register their chips when imported. It is not an import placed in a function to dodge a loop."""
    names = sorted(m.name for m in pkgutil.iter_modules(list(drivers.__path__ if path is None else path))
                   if not m.name.startswith("_"))
    for name in names:
        importlib.import_module(f"{package}.{name}")
    return names


discover()

CHIPS: dict[str, type[Part]] = REGISTERED       # filled by the driver modules' @chip_driver


def chip_class(name: str) -> type[Part]:
    """The registered part class for `name`; ValueError listing every registered chip otherwise."""
    try:
        return CHIPS[name]
    except KeyError:
        raise ValueError(f"unknown chip {name!r}; registered: {sorted(CHIPS)}") from None

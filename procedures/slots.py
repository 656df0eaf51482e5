"""Several boards on one table read as one: the sampler's board (`SlotsBoard`: every slot's triads, named
`<slot>/<kind>`) and the store it records into (`SlotStores`: each slot's rows into that slot's own session).

A slot whose chip stops answering is dropped (`SlotsBoard.drop`, by the sampler): it is read no more, nothing
more is written to its session (its recorded holds are kept, its status says why), and the others go on.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

SEPARATOR = "/"
DROPPED_EVENT = "slot-dropped"


def triad_kind(name: str) -> str:
    """"accel" of "accel" and of "slot-a/accel"."""
    return name.rsplit(SEPARATOR, 1)[-1]


def triad_slot(name: str) -> str | None:
    """The slot of a slot triad's name, None for a one-board name."""
    return name.rsplit(SEPARATOR, 1)[0] if SEPARATOR in name else None


class SlotsBoard:
    """The boards of every slot as one board (`procedures.protocols.Board`) with triads `<slot>/<kind>`."""

    def __init__(self, boards: dict[str, Any]) -> None:
        self.boards = dict(boards)
        self.triads = {f"{slot}{SEPARATOR}{kind}": triad for slot, board in self.boards.items()
                       for kind, triad in board.triads.items()}
        self.dropped: dict[str, str] = {}          # slot -> why it was dropped

    def live(self) -> list[str]:
        return [slot for slot in self.boards if slot not in self.dropped]

    @property
    def parts(self) -> list:
        """The parts of the slots still recorded (a dropped slot's configuration is no longer checked)."""
        return [part for slot in self.live() for part in self.boards[slot].parts]

    def start(self) -> None:
        for slot in self.live():
            self.boards[slot].start()

    def drop(self, slot: str, why: str) -> list[str]:
        """Stop reading `slot`; returns the names of its triads."""
        self.dropped.setdefault(slot, why)
        return [name for name in self.triads if triad_slot(name) == slot]

    def aux_readers(self) -> dict[str, tuple[Callable, Callable]]:
        """Slot -> (its temperature reader, its supply reader): each slot's columns are its own."""
        return {slot: (board.read_temperature, board.read_supply) for slot, board in self.boards.items()}

    def read_temperature(self) -> float | None:
        return None

    def read_supply(self) -> float | None:
        return None

    def settings(self) -> dict:
        return {slot: board.settings() for slot, board in self.boards.items()}


def split_samples(samples: dict[str, np.ndarray]) -> dict[str, dict[str, np.ndarray]]:
    """{"a/accel": ..} -> {"a": {"accel": ..}}."""
    out: dict[str, dict[str, np.ndarray]] = {}
    for name, rows in samples.items():
        out.setdefault(triad_slot(name), {})[triad_kind(name)] = rows
    return out


def _of(value, slot: str):
    """A per-slot column (a dict from `Sampler` on a `SlotsBoard`) for one slot; anything else as it is."""
    return value.get(slot) if isinstance(value, dict) else value


@dataclass
class SlotStores:
    """The procedure's store (`procedures.protocols.Store`) for a table of slots: each call goes to the session
    store of every slot still recorded, with that slot's own samples and columns. `on_drop(slot, why, t)` is told
    once of each slot the board dropped, before anything more is written."""

    stores: dict[str, Any]
    board: SlotsBoard
    on_drop: Callable[[str, str, float | None], None] | None = None
    _told: set = field(default_factory=set)

    def live(self, t: float | None = None) -> list[str]:
        for slot, why in self.board.dropped.items():
            if slot not in self._told:
                self._told.add(slot)
                if self.on_drop is not None:
                    self.on_drop(slot, why, t)
        return self.board.live()

    def append_move(self, step: int, *, t, samples, q_ref, table_deg, temp_c=None, vsupply_v=None) -> None:
        split = split_samples(samples)
        for slot in self.live(float(t[-1]) if len(t) else None):
            self.stores[slot].append_move(step, t=t, samples=split.get(slot, {}), q_ref=q_ref, table_deg=table_deg,
                                          temp_c=_of(temp_c, slot), vsupply_v=_of(vsupply_v, slot))

    def append_hold(self, step: int, *, t, samples, q_ref, table_deg, commanded_deg, measured_deg, temp_c=None,
                    vsupply_v=None, attempt: int = 1) -> None:
        split = split_samples(samples)
        for slot in self.live(float(t[-1]) if len(t) else None):
            self.stores[slot].append_hold(step, t=t, samples=split.get(slot, {}), q_ref=q_ref, table_deg=table_deg,
                                          commanded_deg=commanded_deg, measured_deg=measured_deg,
                                          temp_c=_of(temp_c, slot), vsupply_v=_of(vsupply_v, slot), attempt=attempt)

    def redo(self, t: float, reason: str) -> None:
        for slot in self.live(t):
            self.stores[slot].redo(t, reason)

    def log_event(self, kind: str, message: str, t: float | None = None) -> None:
        """An event about one slot's triad (`<slot>/<kind>: ...`) goes to that slot's session only."""
        named = message.split(SEPARATOR, 1)[0] if SEPARATOR in message.split(" ", 1)[0] else None
        for slot in self.live(t):
            if named is None or named == slot:
                self.stores[slot].log_event(kind, message.removeprefix(f"{slot}{SEPARATOR}") if named else message, t)

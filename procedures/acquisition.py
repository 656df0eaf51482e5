"""Sampling every sensor of a board on one tick grid, on whatever clock the rig runs.

Ticks are scheduled on absolute times (t0 + k/rate) so waiting for data-ready never shifts the grid;
the magnetometer is read every `mag_every` ticks and its other rows stay empty (NaN), as in the
interchange layout. Temperature and supply are read at a few Hz and carried forward.

The grid runs at the output rate of the chips it is aligned to (`grid_rate_hz`): a chip that samples on its own
clock at a rate the grid does not divide (an LSM6DSO offers 104 Hz, not 100) hands over samples whose age against
their time stamps swings through a whole output period at the beat of the two rates, and a move integrated over
those stamps comes out wrong by where that beat falls against each turn.

The board may be the boards of several slots (`procedures.slots.SlotsBoard`): all are read on the one grid,
temperature and supply become per-slot columns, and a slot whose chip is gone is dropped instead of ending the
session.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from drivers import DriverError
from drivers.contract import DataReady, Part, ReadsWhenReady
from procedures.protocols import Board, Store
from procedures.slots import SlotsBoard, triad_kind
from rig.clock import Clock, sleep_until

ABSENT_LIMIT_S = 1.0    # a sensor with no valid sample this long is gone (a cable, a dead chip), not glitching


def output_rate_hz(board: Board, kind: str) -> float | None:
    """The output rate every `kind` triad of `board` reports it samples at on its own clock (`settings()["rate_hz"]`),
    or None when one reports none (it is read on demand) or they differ."""
    rates = set()
    for name, triad in board.triads.items():
        if triad_kind(name) == kind:
            rate = triad.settings().get("rate_hz") if isinstance(triad, Part) else None
            if not rate:
                return None
            rates.add(float(rate))
    return rates.pop() if len(rates) == 1 else None


def grid_rate_hz(board: Board, requested_hz: float, kind: str = "gyro") -> float:
    """The tick grid's rate for `requested_hz` on `board`: the output rate of its `kind` chips (the ones the grid is
    aligned to) divided by the whole number that brings it nearest the request, so that every tick finds exactly
    one new sample at the same age; `requested_hz` itself when those chips are read on demand or disagree."""
    chip_hz = output_rate_hz(board, kind)
    if chip_hz is None:
        return float(requested_hz)
    return chip_hz / max(1, round(chip_hz / requested_hz))


@dataclass
class Recording:
    t: np.ndarray
    samples: dict[str, np.ndarray]
    temp_c: np.ndarray | dict | None         # a dict slot -> column when the board is a `SlotsBoard`
    vsupply_v: np.ndarray | dict | None
    late_reads: int = 0


@dataclass
class Sampler:
    board: Board
    clock: Clock
    rate_hz: float = 100.0
    mag_every: int = 2
    aux_every: int = 10
    session_t0: float = 0.0
    _k: int = 0
    late_reads: int = 0
    skipped_ticks: int = 0
    taken_rows: int = 0                         # rows handed out by `take` so far
    read_errors: list = field(default_factory=list)
    _last_good: dict = field(default_factory=dict)
    gone: set = field(default_factory=set)      # triads of dropped slots: rows stay empty

    def __post_init__(self) -> None:
        self.dt = 1.0 / self.rate_hz
        self.t0 = self.clock.now()
        self._names = list(self.board.triads)
        self._is_mag = {n: triad_kind(n) == "mag" for n in self._names}
        self._ready = {n: tr.data_ready if isinstance(tr, DataReady) else None for n, tr in self.board.triads.items()}
        self._burst = {n: tr.read_if_ready if isinstance(tr, ReadsWhenReady) else None
                       for n, tr in self.board.triads.items()}
        self._slots = isinstance(self.board, SlotsBoard)
        self._aux_of = (self.board.aux_readers() if self._slots
                        else {None: (self.board.read_temperature, self.board.read_supply)})
        self._aux_now = {key: (float("nan"), float("nan")) for key in self._aux_of}
        self._begin()

    def _begin(self) -> None:
        self._t: list[float] = []
        self._rows: dict[str, list] = {n: [] for n in self._names}
        self._aux_rows: dict = {key: ([], []) for key in self._aux_of}

    def tick(self) -> None:
        """Wait for the next grid time and read every sensor due; stamped with the clock time of the reads.

        A loop that fell half a tick or more behind (a slow bus, a busy host, a retried table request) skips
        the missed ticks rather than bursting through them with made-up times or stamping two reads of one
        sample a moment apart; they are counted in `skipped_ticks`.
        """
        t = self.t0 + self._k * self.dt
        late = self.clock.now() - t
        if late >= self.dt / 2:       # read now, and the next tick would come less than half a period later
            behind = int((late - self.dt / 2) // self.dt) + 1
            self._k += behind
            self.skipped_ticks += behind
            t = self.t0 + self._k * self.dt
        sleep_until(self.clock, t)
        stamp = self.stamp(self.clock.now())
        nan3 = (np.nan, np.nan, np.nan)
        due = [n for n in self._names if not ((self._is_mag[n] and self._k % self.mag_every) or n in self.gone)]
        values = self._read_due(due, stamp)
        for name in self._names:
            self._rows[name].append(values.get(name, nan3))
        for key, (read_temperature, read_supply) in self._aux_of.items():
            if self._k % self.aux_every == 0:
                if key is not None and key in self.board.dropped:
                    self._aux_now[key] = (float("nan"), float("nan"))
                else:
                    temp, supply = self._aux(read_temperature, stamp, key), self._aux(read_supply, stamp, key)
                    self._aux_now[key] = (float("nan") if temp is None else temp,
                                          float("nan") if supply is None else supply)
            temps, supplies = self._aux_rows[key]
            temps.append(self._aux_now[key][0])
            supplies.append(self._aux_now[key][1])
        self._t.append(stamp)
        self._k += 1

    def _read_due(self, names: list[str], stamp: float) -> dict:
        """Every sensor in `names` read once this tick, each when its new sample is ready.

        Each chip samples on its own clock, at its own phase against the grid, so at a tick some have a new
        sample and some are a moment from one. A pass polls every sensor still waited for and reads those ready;
        the bus time a pass takes is itself the wait for the others, and only a pass that finds none ready
        sleeps (an eighth of a period) before the next. So a tick costs the sum of its transfers and at most
        one wait, for the last chip, not one wait per chip. A sensor not ready half a period after the tick's
        reads began is read as its registers stand (usually its last sample again), counted in `late_reads`."""
        values: dict = {}
        pending = list(names)
        deadline = self.clock.now() + self.dt / 2
        while True:
            waiting = []
            for name in pending:
                value = self._poll(name, stamp)
                if value is None:
                    waiting.append(name)
                else:
                    values[name] = value
            now = self.clock.now()
            if not waiting or now >= deadline:
                break
            if len(waiting) == len(pending):
                self.clock.sleep(min(self.dt / 8, deadline - now))
            pending = waiting
        for name in waiting:
            self.late_reads += 1
            values[name] = self._read(name, stamp)
        return values

    def _poll(self, name: str, stamp: float):
        """The sensor's sample if its data-ready flag says a new one is there (or it has no flag), else None. A
        chip that reads its flag and sample in one burst is asked once; a poll that fails leaves it to `_read`,
        which retries and records the error."""
        burst, ready = self._burst[name], self._ready[name]
        try:
            if burst is not None:
                value = burst()
                if value is not None:
                    self._last_good[name] = stamp
                return value
            if ready is not None and not ready():
                return None
        except DriverError:
            pass
        return self._read(name, stamp)

    def _read(self, name: str, stamp: float):
        """One read, retried once: a bus glitch (a NACK burst, a parity error) or a saturated sample becomes an
        empty cell and a logged error, not the end of a session; a sensor with no valid sample for
        ABSENT_LIMIT_S is gone, and its last error ends the session (with how long it has been silent)."""
        for attempt in (1, 2):
            try:
                value = self.board.triads[name].read_raw()
            except DriverError as e:
                if attempt == 2:
                    self.read_errors.append((stamp, f"{name}: {e}"))
                    silent = stamp - self._last_good.setdefault(name, stamp)
                    if silent >= ABSENT_LIMIT_S and self._slots:
                        slot = name.split("/", 1)[0]
                        self.gone.update(self.board.drop(slot, f"slot {slot}: {triad_kind(name)} stopped answering "
                                                               f"(no valid sample for {silent:.2f} s: {e})"))
                    elif silent >= ABSENT_LIMIT_S:
                        e.add_note(f"{name}: no valid sample for {silent:.2f} s")
                        raise
            else:
                self._last_good[name] = stamp
                return value
        return (np.nan, np.nan, np.nan)

    def _aux(self, read, stamp: float, slot: str | None = None):
        try:
            return read()
        except DriverError as e:
            self.read_errors.append((stamp, ("" if slot is None else f"{slot}/") + f"temperature/supply: {e}"))
            return None

    def align_to(self, name: str, margin_s: float = 0.0) -> bool:
        """Put the tick grid just after `name`'s own sample instants (found from its data-ready edge).

        A chip that samples on its own clock otherwise hands over samples up to a period older than their
        time stamps: a latency the gyro's move streams and any attitude filter would carry. The edge is
        found coarsely, then again finely one period later. Returns False (grid unchanged) when the chip
        has no data-ready flag or no edge shows within two periods.
        """
        if name not in self._ready:     # several slots: the first slot's triad of that kind sets the grid
            name = next((n for n in self._names if triad_kind(n) == name and n not in self.gone), name)
        ready = self._ready.get(name)
        if ready is None:
            return False
        if self._slots:             # that slot's chip failing now is its own end (`_read`), not the session's
            try:
                return self._align(ready, margin_s)
            except DriverError:
                return False
        return self._align(ready, margin_s)

    def _align(self, ready, margin_s: float) -> bool:
        edge = self._edge(ready, self.dt / 20, 2 * self.dt)
        if edge is None:
            return False
        sleep_until(self.clock, edge + self.dt - self.dt / 10)
        fine = self._edge(ready, self.dt / 1000, self.dt / 5)
        # The edge's own sample was flagged to us already (reading the flag clears it): start with the next.
        self.t0 = (fine if fine is not None else edge + self.dt) + self.dt + margin_s - self._k * self.dt
        return True

    def _edge(self, ready, step: float, span: float) -> float | None:
        """Clock time of the first False -> True transition of `ready`, polled every `step` for `span`."""
        was = bool(ready())
        for _ in range(int(span / step) + 1):
            self.clock.sleep(step)
            now_ready = bool(ready())
            if now_ready and not was:
                return self.clock.now()
            was = now_ready
        return None

    def run(self, ticks: int) -> None:
        for _ in range(ticks):
            self.tick()

    def run_for(self, dt: float) -> None:
        """Sample on the grid until `dt` seconds from now have passed (at least one tick)."""
        end = self.clock.now() + dt
        self.tick()
        while self.now < end:
            self.tick()

    def take(self) -> Recording:
        """Everything since the last take, as arrays; the tick grid continues."""
        columns = {key: tuple(None if np.isnan(c).all() else np.array(c) for c in cols)
                   for key, cols in self._aux_rows.items()}
        if self._slots:
            temp_c, vsupply_v = ({key: c[0] for key, c in columns.items()}, {key: c[1] for key, c in columns.items()})
        else:
            temp_c, vsupply_v = columns[None]
        rec = Recording(np.array(self._t), {n: np.array(v, dtype=float).reshape(-1, 3) for n, v in self._rows.items()},
                        temp_c, vsupply_v, self.late_reads)
        self.taken_rows += len(self._t)
        self._begin()
        return rec

    def so_far(self) -> dict[str, np.ndarray]:
        """Every sensor's samples since the last take, as arrays (the recording goes on)."""
        return {n: np.array(v, dtype=float).reshape(-1, 3) for n, v in self._rows.items()}

    @property
    def rows(self) -> int:
        """Rows recorded since the last take."""
        return len(self._t)

    @property
    def now(self) -> float:
        """Clock time of the next tick."""
        return self.t0 + self._k * self.dt

    def stamp(self, clock_time: float) -> float:
        """Session time (s from session start, continuing across a resume) of a clock reading."""
        return clock_time - self.t0 + self.session_t0


def log_read_errors(store: Store, sampler: "Sampler") -> None:
    """Move the sampler's read errors into the session log (they left empty cells in the data)."""
    for t, message in sampler.read_errors:
        store.log_event("read-error", message, t)
    sampler.read_errors.clear()

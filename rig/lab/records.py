"""What the stores answer with, and the filters every question takes (`--where key=value`, the page's form).

Both stores (PostgreSQL, a folder of SQLite sessions) return these same records, so the questions, the
commands and the web page are written once.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from datetime import date, datetime, timedelta, timezone

from rig.lab.errors import StoreInputError

STATUSES = ("running", "complete", "rejected", "aborted", "failed")
FILTER_KEYS = ("unit", "rig", "operator", "status", "since", "until", "session")


@dataclass
class SessionRow:
    key: str
    name: str
    unit: str
    rig: str
    operator: str
    started: datetime
    status: str
    reason: str = ""
    verdict: str | None = None
    ended: datetime | None = None
    planned: int | None = None
    holds: int = 0
    first_hold: datetime | None = None
    last_hold: datetime | None = None
    simulated: bool = False

    def eta_s(self, now: datetime | None = None) -> float | None:
        """Seconds left of a running session, from the pace of its holds so far."""
        if self.status != "running" or not self.planned or self.holds < 2 or not self.first_hold:
            return None
        pace = (self.last_hold - self.first_hold).total_seconds() / (self.holds - 1)
        now = now or datetime.now(timezone.utc)
        since_last = max(0.0, (now - self.last_hold).total_seconds())
        return max(0.0, pace * (self.planned - self.holds) - since_last)

    def progress(self) -> dict:
        return {"key": self.key, "status": self.status, "holds": self.holds, "planned": self.planned,
                "eta_s": self.eta_s(), "verdict": self.verdict, "reason": self.reason,
                "last_hold_utc": iso(self.last_hold)}


RIG_SOURCE = "rig"
BATCH_PREFIX = "batch "


@dataclass
class CalibrationRecord:
    """One calibration of a session: the rig's own (`source` "rig"), or a batch re-calibration beside it
    ("batch <run>"). A session has at most one of each source."""

    session: str          # the session's name (its folder)
    key: str
    started: datetime
    rig: str
    status: str
    source: str           # "rig" or "batch <run>"
    document: dict        # rig-calibration/1

    def sensors(self) -> dict:
        """Per sensor: B and H with their standard deviations and the unit u = H (y - B) is calibrated to."""
        out = {}
        for name, cal in (self.document.get("sensors") or {}).items():
            if isinstance(cal, dict) and "B" in cal and "H" in cal:
                out[name] = {k: cal.get(k) for k in ("B", "H", "B_std", "H_std", "unit")}
        return out

    @property
    def verdict(self) -> str | None:
        """PASS, FAIL or NOT CHECKED, as the calibration's limits judged it (None: a file that does not say)."""
        verdict = self.document.get("verdict")
        return verdict if isinstance(verdict, str) else None

    @property
    def table(self) -> dict | None:
        """The table this unit shared with others in one session of several slots (`session`, `units`,
        `table_time_s`), None for a unit calibrated alone."""
        table = self.document.get("table")
        return table if isinstance(table, dict) else None

    @property
    def run(self) -> str | None:
        """The batch run that made it (None for the rig's own)."""
        return self.source[len(BATCH_PREFIX):] if self.source.startswith(BATCH_PREFIX) else None


def pick_source(records: list[CalibrationRecord], source: str) -> CalibrationRecord | None:
    """The calibration of one session's `records` that `source` asks for: "rig" (the rig's own), "batch" (the
    latest batch re-calibration) or "batch <run>" (that run's)."""
    if source == "batch":
        batch = [r for r in records if r.run is not None]
        return max(batch, key=lambda r: r.run) if batch else None
    return next((r for r in records if r.source == source), None)


def check_source(source: str) -> str:
    """`source` as `pick_source` takes it; anything else refused with what is allowed."""
    source = " ".join(str(source).replace(":", " ").split())
    if source in (RIG_SOURCE, "batch") or (source.startswith(BATCH_PREFIX) and len(source) > len(BATCH_PREFIX)):
        return source
    raise StoreInputError(f"source {source!r}: give rig (the rig's own calibrations), batch (each session's latest "
                          "batch re-calibration) or batch:RUN (one batch run's)")


@dataclass
class Filters:
    unit: str | None = None
    rig: str | None = None
    operator: str | None = None
    status: list[str] = field(default_factory=list)
    since: date | None = None
    until: date | None = None            # inclusive: sessions started on that day are in
    session: str | None = None           # a key or a folder name

    @classmethod
    def parse(cls, pairs: dict[str, str]) -> "Filters":
        """From key=value pairs; unknown keys, unknown statuses and bad dates are refused with the reason."""
        out = cls()
        for key, value in pairs.items():
            value = str(value).strip()
            if key not in FILTER_KEYS:
                raise StoreInputError(f"unknown filter {key!r}; filters: {', '.join(FILTER_KEYS)}")
            if not value:
                continue
            if key == "status":
                out.status = [s.strip() for s in value.split(",") if s.strip()]
                bad = [s for s in out.status if s not in STATUSES]
                if bad:
                    raise StoreInputError(f"status {bad[0]!r} is not one of {', '.join(STATUSES)}")
            elif key in ("since", "until"):
                try:
                    setattr(out, key, date.fromisoformat(value))
                except ValueError:
                    raise StoreInputError(f"{key}={value!r} is not a date (YYYY-MM-DD)") from None
            else:
                setattr(out, key, value)
        return out

    @classmethod
    def from_where(cls, terms: tuple[str, ...] | list[str]) -> "Filters":
        pairs = {}
        for term in terms:
            key, sep, value = term.partition("=")
            if not sep:
                raise StoreInputError(f"--where {term!r}: give key=value (keys: {', '.join(FILTER_KEYS)})")
            pairs[key.strip()] = value
        return cls.parse(pairs)

    def accepts(self, row: SessionRow) -> bool:
        """The same test the database runs, for the folder store."""
        day = row.started.astimezone(timezone.utc).date()
        return ((self.unit is None or row.unit == self.unit) and (self.rig is None or row.rig == self.rig)
                and (self.operator is None or row.operator == self.operator)
                and (not self.status or row.status in self.status)
                and (self.since is None or day >= self.since) and (self.until is None or day <= self.until)
                and (self.session is None or self.session in (row.key, row.name)))

    def bounds(self) -> tuple[datetime | None, datetime | None]:
        lo = datetime.combine(self.since, datetime.min.time(), timezone.utc) if self.since else None
        hi = (datetime.combine(self.until, datetime.min.time(), timezone.utc) + timedelta(days=1)
              if self.until else None)
        return lo, hi

    def as_query(self) -> dict:
        return {k: v for k, v in (("unit", self.unit), ("rig", self.rig), ("operator", self.operator),
                                  ("status", ",".join(self.status)), ("since", self.since and self.since.isoformat()),
                                  ("until", self.until and self.until.isoformat()), ("session", self.session)) if v}


def iso(when: datetime | None) -> str | None:
    if when is None:
        return None
    return when.astimezone(timezone.utc).isoformat(timespec="milliseconds").replace("+00:00", "Z")


def load_document(text: str, where: str) -> dict:
    try:
        doc = json.loads(text)
    except ValueError as exc:
        raise StoreInputError(f"{where}: not valid JSON ({exc})") from None
    if not isinstance(doc, dict):
        raise StoreInputError(f"{where}: not a calibration document (a JSON object)")
    return doc


def shared_table_line(table: dict | None) -> str | None:
    """"shared table with 4 units, table time 126 s" of a calibration's `table`, None without one."""
    if not isinstance(table, dict) or not isinstance(table.get("units"), int) or table["units"] < 1:
        return None
    t = table.get("table_time_s")
    return (f"shared table with {table['units']} units"
            + (f", table time {float(t):.0f} s" if isinstance(t, (int, float)) else ""))

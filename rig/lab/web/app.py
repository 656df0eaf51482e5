"""`rig serve`: the lab's web page (Starlette, Jinja2 templates, plotly.js from the plotly package).

Read-only by construction: only GET routes, and the database connections are opened with
`default_transaction_read_only`. Everything shown is escaped by the templates (autoescape) or set as text by
the page's script (`textContent`, never HTML); data for the plots travels as JSON in a non-executed script
element. Nothing is fetched from outside the server: plotly.min.js is served from the installed package.
"""

from __future__ import annotations

import json
import math
import re
import threading
import uuid
from datetime import datetime, timezone
from pathlib import Path

import jinja2
import plotly
from starlette.applications import Starlette
from starlette.requests import Request
from starlette.responses import FileResponse, JSONResponse, Response
from starlette.routing import Mount, Route
from starlette.staticfiles import StaticFiles
from starlette.templating import Jinja2Templates

from rig.errors import RigError
from rig.lab import questions
from rig.lab.errors import StoreUnavailable
from rig.lab.identity import parse_utc
from rig.lab.records import (BATCH_PREFIX, RIG_SOURCE, STATUSES, Filters, check_source, iso, pick_source,
                             shared_table_line)
from rig.lab.web import sessionview

HERE = Path(__file__).parent
PLOTLY_JS = Path(plotly.__file__).parent / "package_data" / "plotly.min.js"
PAGE = 100
SECURITY_HEADERS = {
    "Content-Security-Policy": "default-src 'self'; img-src 'self' data:; style-src 'self' 'unsafe-inline'; "
                               "script-src 'self'; object-src 'none'; base-uri 'none'; form-action 'self'",
    "X-Content-Type-Options": "nosniff", "Referrer-Policy": "no-referrer", "X-Frame-Options": "DENY",
}
SAFE_NAME = re.compile(r"^[\w.\-]+$")
RESIDUALS_KEPT = 64             # sessions whose residuals are kept computed


def create_app(store) -> Starlette:
    env = jinja2.Environment(loader=jinja2.FileSystemLoader(HERE / "templates"), autoescape=True,
                             undefined=jinja2.StrictUndefined)
    env.policies["json.dumps_function"] = _dumps
    env.filters["when"] = _when
    env.filters["num"] = _num
    env.filters["shared_table"] = lambda table: shared_table_line(table) or ""
    templates = Jinja2Templates(env=env)
    residual_cache: dict[tuple, dict] = {}
    residual_lock = threading.Lock()

    def page(request: Request, name: str, status: int = 200, **context) -> Response:
        context.update(store=store.describe(), path=request.url.path,
                       skipped=list(dict(getattr(store, "skipped", {}) or {}).values()))
        return templates.TemplateResponse(request, name, context, status_code=status, headers=SECURITY_HEADERS)

    def guarded(handler):
        def run(request: Request) -> Response:
            try:
                return handler(request)
            except StoreUnavailable as exc:
                return _problem(request, page, 503, str(exc))
            except RigError as exc:
                return _problem(request, page, 400, str(exc))
        return run

    def guarded_api(handler):
        """A page's script asks these: the store's trouble as JSON it can show (503: the store is away)."""
        def run(request: Request) -> Response:
            try:
                return handler(request)
            except StoreUnavailable as exc:
                return SafeJSON({"error": str(exc), "store_unavailable": True}, status_code=503,
                                headers=SECURITY_HEADERS)
            except RigError as exc:
                return SafeJSON({"error": str(exc)}, status_code=400, headers=SECURITY_HEADERS)
        return run

    def sessions(request: Request) -> Response:
        filters = Filters.parse({k: v for k, v in request.query_params.items() if k != "page"})
        number = _int(request.query_params.get("page"), 1)
        rows, total = store.sessions(filters, limit=PAGE, offset=(number - 1) * PAGE)
        return page(request, "sessions.html", rows=rows, total=total, number=number, pages=max(1, -(-total // PAGE)),
                    filters=filters, query=filters.as_query(), names=store.names(), statuses=STATUSES,
                    live={"query": filters.as_query(), "newest": iso(rows[0].started) if rows else None,
                          "first_page": number == 1})

    def sessions_api(request: Request) -> Response:
        """The sessions matching the list's filters that started after `after` (the newest the list shows),
        newest first, and how many match in all: the list adds them as they appear."""
        filters = Filters.parse({k: v for k, v in request.query_params.items() if k != "after"})
        after = request.query_params.get("after")
        rows, total = store.sessions(filters, limit=PAGE)
        if after:
            try:
                bound = parse_utc(after)
            except ValueError:
                return SafeJSON({"error": f"after={after!r} is not a time"}, status_code=400, headers=SECURITY_HEADERS)
            rows = [r for r in rows if r.started > bound]
        return SafeJSON({"sessions": [_listed(r) for r in rows], "total": total,
                         "now": iso(datetime.now(timezone.utc))}, headers=SECURITY_HEADERS)

    def progress(request: Request) -> Response:
        keys = [k for k in request.query_params.get("keys", "").split(",") if _is_key(k)][:PAGE]
        rows = [store.session(k) for k in keys]
        return SafeJSON({"sessions": [r.progress() for r in rows if r is not None],
                             "now": iso(datetime.now(timezone.utc))}, headers=SECURITY_HEADERS)

    def session(request: Request) -> Response:
        row = _session_or_404(store, request.path_params["key"])
        if row is None:
            return _problem(request, page, 404, "no such session in this store")
        meta = store.metadata(row.key)
        records = store.calibrations(key=row.key)
        own = pick_source(records, RIG_SOURCE)
        shown = own or pick_source(records, "batch")
        results = store.results(row.key)
        checks_of = {r["run"]: r["document"].get("checks") for r in results
                     if r["kind"] == "calibrate" and isinstance(r.get("document"), dict)}
        calibrations = []
        for record in ([shown] if shown else []) + [r for r in records if r is not shown]:
            units = {x["sensor"]: x["unit"] for x in sessionview.sensor_rows(record)}
            checks = sessionview.report_checks(store, row.key) if record.run is None else checks_of.get(record.run)
            calibrations.append({"record": record, "rows": sessionview.sensor_rows(record),
                                 "file": sessionview.calibration_file_name(record),
                                 "checks": sessionview.check_rows(checks, units) if checks is not None else None,
                                 "change": questions.change(shown, record) if record is not shown else None})
        files = [(name, media) for name, media in store.artifacts(row.key)]
        files = [(c["file"], "application/json") for c in calibrations] + files
        return page(request, "session.html", row=row, meta=meta, calibrations=calibrations, files=files,
                    table=shown.table if shown else None,
                    session_file=sessionview.SESSION_NAME, events=store.events(row.key),
                    holds=store.hold_means(row.key), results=results, z_flag=questions.Z_FLAG)

    def residuals_api(request: Request) -> Response:
        """The residual of every orientation of the session's calibration (the rig's own, else the latest batch
        one): computed from the stored session once per calibration and kept."""
        row = _session_or_404(store, request.path_params["key"])
        if row is None:
            return SafeJSON({"error": "no such session"}, status_code=404, headers=SECURITY_HEADERS)
        records = store.calibrations(key=row.key)
        record = pick_source(records, RIG_SOURCE) or pick_source(records, "batch")
        if record is None:
            return SafeJSON({"sensors": {}, "source": None}, headers=SECURITY_HEADERS)
        cache_key = (row.key, record.source, json.dumps(record.document, sort_keys=True, default=str))
        with residual_lock:
            found = residual_cache.get(cache_key)
        if found is None:
            try:
                found = {**sessionview.residuals(store.session_data(row.key), record.document),
                         "source": record.source}
            except (ValueError, ArithmeticError, KeyError) as exc:
                found = {"sensors": {}, "source": record.source, "error": f"the residuals cannot be computed: {exc}"}
            with residual_lock:
                residual_cache[cache_key] = found
                while len(residual_cache) > RESIDUALS_KEPT:
                    residual_cache.pop(next(iter(residual_cache)))
        return SafeJSON(found, headers=SECURITY_HEADERS)

    def session_api(request: Request) -> Response:
        row = _session_or_404(store, request.path_params["key"])
        if row is None:
            return SafeJSON({"error": "no such session"}, status_code=404, headers=SECURITY_HEADERS)
        after = _int(request.query_params.get("after"), 0, low=0)
        holds = [h for h in store.hold_means(row.key) if h["seq"] > after]
        for h in holds:
            h["written_utc"] = iso(h["written_utc"]) if isinstance(h["written_utc"], datetime) else h["written_utc"]
        return SafeJSON({"progress": row.progress(), "holds": holds}, headers=SECURITY_HEADERS)

    def artifact(request: Request) -> Response:
        """A file of the session: its report and figures, its calibrations, its session file. Shown as text or an
        image (never rendered as a page), or with `?download=1` saved under its name."""
        key, name = request.path_params["key"], request.path_params["name"]
        if not _is_key(key) or not SAFE_NAME.match(name):
            return Response("not found", status_code=404, media_type="text/plain")
        found = _session_file(store, key, name)
        if found is None:
            return Response("not found", status_code=404, media_type="text/plain")
        media, content = found
        headers = dict(SECURITY_HEADERS)
        if request.query_params.get("download"):
            headers["Content-Disposition"] = f'attachment; filename="{name}"'
            media = media if media.startswith(("image/png", "application/json")) else "application/octet-stream"
        elif not media.startswith("image/png"):
            media = "text/plain; charset=utf-8"        # a report is shown as text, never rendered as a page
        return Response(content, media_type=media, headers=headers)

    def units(request: Request) -> Response:
        return page(request, "units.html", units=store.units())

    def unit(request: Request) -> Response:
        serial = request.path_params["serial"]
        source = check_source(request.query_params.get("source") or RIG_SOURCE)
        data = questions.history(store, serial, source)
        if not data["calibrations"] and serial not in store.names()["units"]:
            return _problem(request, page, 404, f"no unit {serial!r} in this store")
        units = {s: c.get("unit") for e in data["calibrations"] for s, c in e["sensors"].items() if c.get("unit")}
        return page(request, "unit.html", serial=serial, data=data, source=source, sensor_units=units,
                    sensors=sorted({s for e in data["calibrations"] for s in e["sensors"]}),
                    rigs=sorted({e["rig"] for e in data["calibrations"]}))

    def rigs(request: Request) -> Response:
        serial = request.query_params.get("unit", "")
        data = questions.compare_rigs(store, serial) if serial else None
        return page(request, "rigs.html", serial=serial, data=data, names=store.names())

    def pass_fail(request: Request) -> Response:
        filters = Filters.parse(dict(request.query_params.items()))
        return page(request, "passfail.html", data=questions.pass_fail(store, filters), filters=filters,
                    names=store.names(), statuses=STATUSES)

    def plotly_js(request: Request) -> Response:
        return FileResponse(PLOTLY_JS, media_type="text/javascript", headers={"Cache-Control": "max-age=86400"})

    routes = [Route("/", guarded(sessions)), Route("/api/progress", guarded_api(progress)),
              Route("/api/sessions", guarded_api(sessions_api)),
              Route("/session/{key}", guarded(session)), Route("/api/session/{key}", guarded_api(session_api)),
              Route("/api/session/{key}/residuals", guarded_api(residuals_api)),
              Route("/session/{key}/file/{name}", guarded(artifact)), Route("/units", guarded(units)),
              Route("/unit/{serial:path}", guarded(unit)), Route("/rigs", guarded(rigs)),
              Route("/pass-fail", guarded(pass_fail)), Route("/static/plotly.min.js", plotly_js),
              Route("/favicon.ico", lambda request: Response(status_code=204)),
              Mount("/static", StaticFiles(directory=HERE / "static"), name="static")]
    return Starlette(routes=routes)


class SafeJSON(JSONResponse):
    def render(self, content) -> bytes:
        return _dumps(content).encode()


def _session_file(store, key: str, name: str) -> tuple[str, bytes] | None:
    """(media type, bytes) of a session's file by the name the page lists it under, None if it has none."""
    if name == sessionview.SESSION_NAME:
        return ("application/vnd.sqlite3", store.session_file(key)) if store.session(key) is not None else None
    if name == sessionview.CALIBRATION_NAME or (name.startswith("calibration-") and name.endswith(".json")):
        source = RIG_SOURCE if name == sessionview.CALIBRATION_NAME else \
            BATCH_PREFIX + name.removeprefix("calibration-").removesuffix(".json")
        text = store.calibration_text(key, source)
        return None if text is None else ("application/json", text.encode())
    return store.artifact(key, name)


def _listed(row) -> dict:
    """A session as the list's script adds it: the same cells as the list's template."""
    return {"key": row.key, "name": row.name, "unit": row.unit, "rig": row.rig, "operator": row.operator,
            "started": _when(row.started), "started_utc": iso(row.started), **row.progress()}


def _problem(request: Request, page, status: int, message: str) -> Response:
    return page(request, "problem.html", status=status, message=message)


def _session_or_404(store, key: str):
    return store.session(key) if _is_key(key) else None


def _is_key(text: str) -> bool:
    try:
        uuid.UUID(text)
    except ValueError:
        return False
    return True


def _int(text: str | None, default: int, low: int = 1) -> int:
    try:
        return max(low, int(text)) if text else default
    except ValueError:
        return default


def _dumps(obj, **kw) -> str:
    """JSON for the page's scripts: NaN and infinities become null (JSON.parse refuses them)."""
    return json.dumps(_finite(obj), default=_default, **kw)


def _finite(value):
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {str(k): _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    return value


def _default(value):
    if isinstance(value, datetime):
        return iso(value)
    return str(value)


def _when(value) -> str:
    if value is None:
        return "-"
    if isinstance(value, str):
        return value
    return value.astimezone(timezone.utc).strftime("%Y-%m-%d %H:%M:%S") + "Z"


def _num(value, digits: int = 4) -> str:
    """A number to `digits` significant digits; one that rounds to zero is 0, never "-0"."""
    if value is None:
        return "-"
    try:
        text = f"{float(value):.{digits}g}"
    except (TypeError, ValueError):
        return str(value)
    return text.lstrip("-") if float(text) == 0 else text

"""The lab: many rigs, one central store, questions across sessions, a web page and batch analysis.

A rig always records locally first (`rig.store`, one SQLite file per session folder); the central store on
PostgreSQL is a mirror that `rig push` (or a live mirror beside a running session) fills with what it does
not have yet, idempotently. The questions (`units`, `history`, `compare-rigs`, pass/fail) and the web page
read either the central store or a folder of SQLite sessions, through one interface (`open_store`).
"""

#!/usr/bin/env bash
# Runs the whole test suite on a fresh machine: Debian packages the tests need, a venv, the package, pytest.
set -euo pipefail
cd "$(dirname "$0")/.."
if ! command -v mbpoll >/dev/null 2>&1; then
    if [ "$(id -u)" = 0 ]; then
        (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq mbpoll) >/dev/null
    else
        echo "scripts/test.sh: the tests need Debian's mbpoll: sudo apt-get install -y mbpoll" >&2
        exit 2
    fi
fi
[ -d .venv ] || python3 -m venv .venv
. .venv/bin/activate
python -m pip install -q --upgrade pip >/dev/null
python -m pip install -q -e '.[test]'
python -m pytest "$@"

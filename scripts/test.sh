#!/usr/bin/env bash
# Runs the whole test suite on a fresh machine: Debian packages the tests need, a venv, the package, pytest.
set -euo pipefail
cd "$(dirname "$0")/.."
# Debian packages: mbpoll (a Modbus client), postgresql (the lab's tests start their own server),
# chromium and chromium-driver (the lab's web page is checked in a real headless browser)
missing=()
for pkg in mbpoll postgresql chromium chromium-driver; do
    dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" || missing+=("$pkg")
done
if [ ${#missing[@]} -gt 0 ]; then
    if [ "$(id -u)" = 0 ]; then
        (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing[@]}") >/dev/null
    else
        echo "scripts/test.sh: the tests need Debian's ${missing[*]}: sudo apt-get install -y ${missing[*]}" >&2
        exit 2
    fi
fi
[ -d .venv ] || python3 -m venv .venv
. .venv/bin/activate
python -m pip install -q --upgrade pip >/dev/null
python -m pip install -q -e '.[test]'
# A whole run (no arguments) spreads the test files over the machine's cores (at most four: each worker may start its
# own PostgreSQL server and browser), then runs the numerical tests a second time on another BLAS kernel of this CPU
# and one BLAS thread, so that a test which holds only for one machine's floating point fails here first: the fits
# and their uncertainty, in process; the filters, the twins and the commands on whole recordings are left to the
# first pass (the run must stay within its time). Arguments go to pytest as given, in one process.
if [ $# -gt 0 ]; then
    exec python -m pytest "$@"
fi
workers=(-n auto --maxprocesses 4 --dist loadfile)
python -m pytest "${workers[@]}" --durations=60
other=$(python scripts/other_blas.py)
echo "second pass: numerical tests with ${other:-the same kernel} and one BLAS thread"
env $other OPENBLAS_NUM_THREADS=1 python -m pytest -p no:cacheprovider "${workers[@]}" \
    tests/calibration_vector tests/calibration_gyro tests/calibration_thermal tests/planner \
    tests/recordings/test_carry_weight.py tests/recordings/test_noise_terms.py \
    tests/recordings/test_noise_level_dof.py tests/recordings/test_norm_fit_uncertainty.py \
    tests/recordings/test_quasi_static.py tests/recordings/test_loo_scatter.py \
    tests/recordings/test_g_sensitivity_calibration.py tests/recordings/test_warm_up.py \
    tests/recordings/test_fit_jacobians.py

"""The fits' linear algebra on one BLAS thread.

The calibration's matrices are small (the move rows of a session: a few thousand rows by 15; a recording's gyro
Jacobian: a few thousand by nine), where BLAS threads only spin against each other, and the twin's replicas
already run one per core. Measured on the 2-core machine under load: the SVD of a 7182 x 15 Jacobian 2.5 ms on one
thread against 165 ms on two (a simulated session's calibration 1.15 -> 0.11 s), of a 3800 x 9 one 0.35 ms against
7-26 ms (the Xsens twin 91 -> 59 CPU-s); the results bit-identical.
"""

from __future__ import annotations

from threadpoolctl import threadpool_limits


def one_blas_thread() -> threadpool_limits:
    """A context in which BLAS runs on one thread."""
    return threadpool_limits(limits=1, user_api="blas")

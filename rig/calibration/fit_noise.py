"""What a weighted least-squares fit's residuals say of their noise (the magnetometer's, `mag_fit`).

A group's residual RMS understates its noise by the share of its rows the fit spends on its parameters: a
magnetometer's 20 still poses fix its rotation and the field's dip, and their RMS alone made the covariance too
small (40 noise draws of two synthetic hand sessions scattered 0.80 to 1.29 and 1.06 to 1.39 times the stated
deviation of B's and H's entries; with each group's redundancy 0.72 to 1.11 and 0.92 to 1.29).
"""

from __future__ import annotations

import numpy as np


def group_sigmas(r: np.ndarray, J: np.ndarray, kinds: np.ndarray) -> np.ndarray:
    """Each group's noise standard deviation, in the units of its unweighted residuals, from the weighted
    residuals' Jacobian J (rows, parameters), the unweighted residuals r and each row's group `kinds` (0, 1, ...):
    its sum of squares over its redundancy, the sum of its rows' 1 - h_ii (h the hat matrix
    J (J^T J)^-1 J^T): Förstner's estimate of variance components (W. Förstner, "Ein Verfahren zur Schätzung von
    Varianz- und Kovarianzkomponenten", Allgemeine Vermessungs-Nachrichten 86, 1979; redundancy numbers:
    Förstner, CVGIP 40, 1987, 273-310)."""
    leverage = np.einsum("ij,ij->i", J @ np.linalg.pinv(J.T @ J), J)
    out = []
    for k in range(int(kinds.max()) + 1):
        mine = kinds == k
        redundancy = max(float(np.sum(1.0 - leverage[mine])), 1.0)
        out.append(float(np.sqrt(np.sum(r[mine] ** 2) / redundancy)))
    return np.array(out)


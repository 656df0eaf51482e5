"""A magnetometer logged by itself and turned by hand: hard and soft iron from every sample, in its own frame.

Model (Vasconcelos, Elkaim, Silvestre, Oliveira and Cardeira, "Geometric approach to strapdown magnetometer
calibration in sensor frame", IEEE Trans. Aerospace and Electronic Systems 47(2), 2011, its sensor model): a
sample is `y_k = T h_k + b + n_k`, the field `h_k` of one magnitude in every attitude, `n_k` white noise of one
deviation on every raw axis. Nothing but the magnitude is known, so the samples fix an ellipsoid and nothing
turns it: T is determined up to a rotation, and the calibration `u = H (y - B)` takes the symmetric
positive-definite `H = F (T T^T)^(-1/2)` (F the field's magnitude), the magnetometer's own frame. The papers'
texts could not be retrieved here: they are cited by what they do, not by equation number.

1. Start: the algebraic ellipsoid through the samples (`ellipsoid.fit_ellipsoid`, one linear solve of the
   quadric `y^T M y + 2 m^T y = 1`; Li and Griffiths, "Least squares ellipsoid specific fitting", Geometric
   Modeling and Processing 2004, add a constraint that keeps the quadric an ellipsoid, which a tumbled sensor's
   samples keep unasked).
2. Maximum likelihood (Vasconcelos et al. 2011, their maximum likelihood estimator): with Gaussian noise the
   likelihood is greatest where the sum of squared distances from the samples to the ellipsoid
   `{B + S^-1 u : |u| = 1}` is least (their cost over T, b and the unit fields h_k, the h_k eliminated as each
   sample's nearest point). The distance is taken to first order in the noise:
   `r_k = (|S d_k| - 1) / |S e_k|`, `d_k = y_k - B`, `e_k = S d_k / |S d_k|`, the algebraic residual over its
   gradient in y (the gradient-weighted distance of Sampson, Computer Graphics and Image Processing 18, 1982,
   and Taubin, IEEE Trans. PAMI 13, 1991). Minimised over B and the six entries of the symmetric S by
   Levenberg-Marquardt (scipy's `least_squares`, MINPACK) with the analytic Jacobian below.
3. Bias: the distances of noisy samples are not zero-mean at the truth (a noisy point lies outside its sphere
   on average, the "essential bias" of geometric fits; Al-Sharadqah and Chernov, Electronic Journal of
   Statistics 3, 2009), which moves the estimate by O(sigma^2) where its deviation shrinks as sigma / sqrt(n):
   about sigma sqrt(n) of its deviations (sigma relative to the field), 0.5 with 0.3 uT in 48 uT and 6000
   samples. The estimating equation's expectation at the truth is `sigma^2 / 2 sum_k Laplacian_y (J_k^T r_k)`
   (second order in the noise), taken here by central differences in y, and removed by one Gauss-Newton step.
4. Covariance: `s^2 (J^T J)^-1`, J the residuals' Jacobian, s^2 the residuals' scatter over n - 9 degrees of
   freedom (Seber and Wild, Nonlinear Regression, 1989, sec. 2.1), widened where the residuals depend on each
   other over time (`_correlation_factor`): a slowly varying field, a smoothing filter or a model error shared
   by one sweep makes neighbouring samples one piece of evidence.

Refused only where the samples leave the nine parameters undetermined: their directions span too little of the
sphere for the ellipsoid's shape (the message says how much they cover, and where the samples never point).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from rig.calibration.numerics.ellipsoid import fit_ellipsoid, sphere_map
from rig.calibration.numerics.field_norm import to_data_field
from rig.calibration.numerics.result import TriadCalibration
from rig.errors import CalibrationError

MAX_SAMPLES = 20_000         # every k-th sample beyond this: the sphere is as well covered, the fit faster
MIN_SAMPLES = 30
MAX_RELATIVE_SD = 0.02       # of the field: an entry of B or H known worse than this is not calibrated
MAX_MAGNITUDE_RMS = 0.1      # of the field: samples whose magnitudes scatter more are on no one ellipsoid
OUTLIER_SIGMAS = 6.0         # a sample this far from the ellipsoid (robust deviations) is not the Earth's field
COVERAGE_CELLS = 200         # equal-area cells of the sphere, for the share the directions cover
BLOCKS = 20                  # of consecutive samples, for the residuals' dependence (`_correlation_factor`)
BLOCK_SIGNIFICANT = 1.55     # 0.87 + 3 x 0.18 (`_correlation_factor`)
LAPLACE_STEP = 1e-3          # of the field, the central differences' step in y
UPPER = np.triu_indices(3)
_SYM_BASIS = np.zeros((6, 3, 3))
for _p, (_i, _j) in enumerate(zip(*UPPER)):
    _SYM_BASIS[_p, _i, _j] = _SYM_BASIS[_p, _j, _i] = 1.0
DUPLICATION = _SYM_BASIS.reshape(6, 9).T          # vec(S) = D s, s the upper entries


@dataclass
class SphereFit:
    """B (raw), the symmetric S onto the unit sphere, their covariance (9: B then S's upper entries), and how."""

    B: np.ndarray
    S: np.ndarray
    cov: np.ndarray
    sigma: float                 # the raw noise deviation the residuals show
    correlation_factor: float
    iterations: int
    converged: bool
    samples: int
    left_out: int
    coverage: float              # share of the sphere's directions with a sample
    residual_rms: float          # | |S (y - B)| - 1 |, of the unit field


def calibrate_mag_alone(y: np.ndarray, field_uT: float | None, *, source: str,
                        raw_unit: str = "counts") -> tuple[TriadCalibration, list[str]]:
    """The magnetometer of raw samples y (n, 3; NaN rows skipped) in its own frame, and warnings. `field_uT`: the
    local field magnitude; None: the data's own (`field_norm`), said in a warning and in the result's extra."""
    y = np.asarray(y, dtype=float)
    y = y[np.isfinite(y).all(axis=1)]
    warnings: list[str] = []
    fit = fit_sphere(y, what=f"{source}: mag")
    if fit.left_out:
        warnings.append(f"mag: {fit.left_out} of {fit.samples + fit.left_out} samples lie more than "
                        f"{OUTLIER_SIGMAS:g} noise deviations off the ellipsoid the others fix (a magnet or iron "
                        "passing by) and were left out")
    D = np.zeros((12, 9))
    D[:3, :3] = np.eye(3)
    D[3:, 3:] = DUPLICATION
    cov = D @ fit.cov @ D.T                                  # (B, vec S), S's symmetric entries counted twice
    extra = {"frame": "mag", "samples": fit.samples, "sphere_coverage": round(fit.coverage, 3),
             "noise_raw": fit.sigma, "residual_correlation_factor": fit.correlation_factor}
    if field_uT:
        H, H_cov = field_uT * fit.S, cov[3:, 3:] * field_uT ** 2
        extra["field_uT_source"] = "given"
        norm = float(field_uT)
    else:
        scaled = to_data_field(fit.S, 1.0, cov[3:, 3:])
        H, H_cov, norm = scaled.H, scaled.H_cov, scaled.field
        extra.update({"field_uT_source": "data", "field_magnitude": norm, "field_magnitude_std": scaled.field_std,
                      "field_magnitude_unit": raw_unit})
        if raw_unit != "uT":
            extra["unit"] = raw_unit
        warnings.append(field_from_data_warning(norm, scaled.field_std, raw_unit))
    cal = TriadCalibration(
        B=fit.B, H=H, method="magnetometer alone (ellipsoid, maximum likelihood; symmetric H: its own frame)",
        residual_rms=fit.residual_rms * norm, iterations=fit.iterations, converged=fit.converged,
        B_std=np.sqrt(np.clip(np.diag(cov[:3, :3]), 0, None)),
        H_std=np.sqrt(np.clip(np.diag(H_cov), 0, None)).reshape(3, 3), B_cov=cov[:3, :3], H_cov=H_cov, extra=extra)
    return cal, warnings


def field_from_data_warning(norm: float, sd: float, raw_unit: str) -> str:
    """What a magnetometer calibrated without the local field magnitude says."""
    where = (f"{norm:.4g} +/- {sd:.2g} uT" if raw_unit == "uT" else
             f"{norm:.4g} +/- {sd:.2g} {raw_unit} (its raw unit: the calibrated output is in {raw_unit} too, not uT)")
    return (f"mag: no field_uT in the recording: calibrated to the field magnitude its own samples show, {where}, "
            "taking the soft iron to keep the sphere's volume (det H = 1); give the local field with "
            "`rig import ... --field-uT` (a geomagnetic model such as the WMM gives it) for H in absolute terms")


def fit_sphere(y: np.ndarray, *, what: str) -> SphereFit:
    """B and the symmetric S with |S (y - B)| = 1 from raw samples y (n, 3), maximum likelihood, bias removed,
    with their covariance; CalibrationError where the samples do not determine them (naming their coverage)."""
    if len(y) < MIN_SAMPLES:
        raise CalibrationError(f"{what}: {len(y)} samples; an ellipsoid's nine parameters need at least "
                               f"{MIN_SAMPLES} spread over the sphere")
    y = y[::max(1, len(y) // MAX_SAMPLES)]
    try:
        start = fit_ellipsoid(y, what=what, check_repeats=False)
    except CalibrationError as exc:
        raise CalibrationError(f"{what}: the samples do not bound an ellipsoid ({_coverage_text(y, None, None)}); "
                               "turn the sensor through every orientation, not about one axis") from exc
    centre, radius = start.center, float(np.sqrt(np.mean(np.sum((y - start.center) ** 2, axis=1))))
    z = (y - centre) / radius                           # scaled: B near 0, S near I, whatever the raw unit
    S0 = sphere_map(start, 1.0) * radius
    x0 = np.concatenate([np.zeros(3), S0[UPPER]])
    x, res = _solve(z, x0)
    r = res.fun
    robust = 1.4826 * float(np.median(np.abs(r)))
    keep = np.abs(r) <= OUTLIER_SIGMAS * max(robust, np.finfo(float).tiny)
    left_out = int((~keep).sum())
    if left_out:
        z = z[keep]
        x, res = _solve(z, x)
        r = res.fun
    n = len(z)
    J = res.jac
    A = J.T @ J
    if not np.all(np.isfinite(A)) or np.linalg.cond(A) > 1e12:
        raise CalibrationError(f"{what}: the samples do not determine the ellipsoid "
                               f"({_coverage_text(z, *_unpack(x))})")
    A_inv = np.linalg.inv(A)
    sigma2 = float(r @ r) / max(n - 9, 1)
    x = x + A_inv @ (0.5 * sigma2 * _laplacian_score(x, z))     # step 3: the noise's bias removed
    factor = _correlation_factor(J, r, A_inv)
    cov = A_inv * sigma2 * factor
    B, S = _unpack(x)
    if not np.all(np.linalg.eigvalsh(S) > 0):
        raise CalibrationError(f"{what}: the fitted shape is not an ellipsoid ({_coverage_text(z, B, S)})")
    v = np.linalg.norm((z - B) @ S, axis=1)
    residual_rms = float(np.sqrt(np.mean((v - 1.0) ** 2)))
    if residual_rms > MAX_MAGNITUDE_RMS:
        raise CalibrationError(f"{what}: the samples do not lie on one ellipsoid: their magnitudes scatter "
                               f"{100 * residual_rms:.2g} % about the best one; {_coverage_text(z, None, None)} (a "
                               "field that changes while the sensor turns, or too little of the sphere turned through)")
    relative = np.sqrt(np.diag(cov))                 # B and S in units of the field: S is near I, B near 0
    if relative.max() > MAX_RELATIVE_SD:
        worst = int(np.argmax(relative))
        name = f"B[{worst}]" if worst < 3 else f"H[{UPPER[0][worst - 3]}, {UPPER[1][worst - 3]}]"
        raise CalibrationError(f"{what}: the samples leave the ellipsoid undetermined: {name} is known to only "
                               f"{100 * relative.max():.2g} % of the field (at most {100 * MAX_RELATIVE_SD:g} %); "
                               f"{_coverage_text(z, B, S)}: turn the sensor through more of the sphere")
    scale = np.r_[np.full(3, radius), np.full(6, 1.0 / radius)]
    return SphereFit(B=centre + radius * B, S=S / radius, cov=cov * np.outer(scale, scale),
                     sigma=float(np.sqrt(sigma2)) * radius, correlation_factor=factor, iterations=int(res.nfev),
                     converged=bool(res.success), samples=n,
                     left_out=left_out, coverage=coverage(_directions(z, B, S)),
                     residual_rms=residual_rms)


def _solve(z: np.ndarray, x0: np.ndarray):
    """Levenberg-Marquardt from x0; the residuals and Jacobian of one x computed once for both calls."""
    last: dict = {}

    def both(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if "x" not in last or not np.array_equal(last["x"], x):
            last["x"], last["value"] = x.copy(), _residuals_and_jacobian(x, z)
        return last["value"]

    res = least_squares(lambda x: both(x)[0], x0, jac=lambda x: both(x)[1], method="lm", xtol=1e-12, ftol=1e-12,
                        gtol=1e-12, max_nfev=100)
    return res.x, res


def _unpack(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    S = np.zeros((3, 3))
    S[UPPER] = x[3:]
    S[(UPPER[1], UPPER[0])] = x[3:]
    return x[:3], S


def _residuals_and_jacobian(x: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """r_k = (rho - 1) / w, rho = |S d|, w = |S e|, e = S d / rho, d = z - B, and dr / dx (n, 9).

    With f = S e, u = f / w, for a change dS (symmetric) and dB: dv = dS d - S dB, drho = e . dv,
    de = (dv - e (e . dv)) / rho, dw = u . (dS e + S de), dr = drho / w - (rho - 1) dw / w^2."""
    B, S = _unpack(x)
    d = z - B
    v = d @ S
    rho = np.linalg.norm(v, axis=1)
    e = v / rho[:, None]
    f = e @ S
    w = np.linalg.norm(f, axis=1)
    u = f / w[:, None]
    dS = np.concatenate([np.zeros((3, 3, 3)), _SYM_BASIS])                   # (9, 3, 3)
    dv = np.einsum("pij,nj->npi", dS, d)
    dv[:, :3, :] -= S.T[None]                                               # dB_j: -S e_j = -S[:, j]
    drho = np.einsum("ni,npi->np", e, dv)
    de = (dv - e[:, None, :] * drho[:, :, None]) / rho[:, None, None]
    df = np.einsum("pij,nj->npi", dS, e) + np.einsum("ij,npj->npi", S, de)
    dw = np.einsum("ni,npi->np", u, df)
    r = (rho - 1.0) / w
    J = drho / w[:, None] - ((rho - 1.0) / w ** 2)[:, None] * dw
    return r, J


def _laplacian_score(x: np.ndarray, z: np.ndarray) -> np.ndarray:
    """sum_k of the Laplacian in y of J_k^T r_k (9,), by central differences."""
    def score(zz: np.ndarray) -> np.ndarray:
        r, J = _residuals_and_jacobian(x, zz)
        return J * r[:, None]

    h = LAPLACE_STEP
    centre = score(z)
    total = np.zeros(9)
    for i in range(3):
        step = np.zeros(3)
        step[i] = h
        total += np.sum(score(z + step) + score(z - step) - 2.0 * centre, axis=0)
    return total / (h * h)


def _correlation_factor(J: np.ndarray, r: np.ndarray, A_inv: np.ndarray) -> float:
    """How much the residuals' dependence widens the covariance: the cluster-robust sandwich
    `A^-1 (sum_b s_b s_b^T) A^-1 G / (G - 1)`, s_b = J_b^T r_b summed over each of G blocks of consecutive
    samples (the robust variance of Liang and Zeger, Biometrika 73, 1986, with time blocks as the clusters),
    against the covariance of independent samples, averaged over the parameters. A field disturbed for seconds, a
    smoothing filter, or a model error shared by the samples of one sweep make the samples of a block one piece of
    evidence: on the two real logs of a QMC5883L turned by hand for 7 minutes the ratio was 10 and 31. Taken only where
    it exceeds BLOCK_SIGNIFICANT: on white noise it measured 0.87 +/- 0.18 over 60 synthetic tumbles (at most 1.3)."""
    n = len(r)
    blocks = min(BLOCKS, n // 20)
    if blocks < 2:
        return 1.0
    scores = np.array([J[b].T @ r[b] for b in np.array_split(np.arange(n), blocks)])
    clustered = np.diag(A_inv @ (scores.T @ scores) @ A_inv) * blocks / (blocks - 1)
    plain = np.diag(A_inv) * float(r @ r) / max(n - 9, 1)
    ratio = float(np.mean(clustered / np.where(plain > 0, plain, np.inf)))
    return ratio if ratio > BLOCK_SIGNIFICANT else 1.0


def _directions(z: np.ndarray, B: np.ndarray | None, S: np.ndarray | None) -> np.ndarray:
    v = (z - (z.mean(axis=0) if B is None else B)) @ (np.eye(3) if S is None else S)
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def coverage(directions: np.ndarray, cells: int = COVERAGE_CELLS) -> float:
    """The share of `cells` equal-area cells of the sphere (a Fibonacci lattice's nearest-point cells) that hold a
    direction."""
    centres = fibonacci_sphere(cells)
    nearest = np.argmax(directions @ centres.T, axis=1)
    return len(np.unique(nearest)) / cells


def fibonacci_sphere(n: int) -> np.ndarray:
    """n nearly evenly spread unit vectors (the golden-angle spiral)."""
    k = np.arange(n) + 0.5
    zc = 1.0 - 2.0 * k / n
    phi = np.pi * (3.0 - np.sqrt(5.0)) * k
    rc = np.sqrt(1.0 - zc * zc)
    return np.column_stack([rc * np.cos(phi), rc * np.sin(phi), zc])


def _coverage_text(z: np.ndarray, B: np.ndarray | None, S: np.ndarray | None) -> str:
    """How much of the sphere the samples' directions cover, and the direction farthest from all of them."""
    return directions_text(_directions(z, B, S), "magnetometer")


def directions_text(e: np.ndarray, sensor: str) -> str:
    """How much of the sphere unit directions e (n, 3) cover, and the direction farthest from all of them, in the
    `sensor`'s axes."""
    grid = fibonacci_sphere(2000)
    nearest = np.max(grid @ e[:: max(1, len(e) // 4000)].T, axis=1)
    far = int(np.argmin(nearest))
    gap = float(np.degrees(np.arccos(np.clip(nearest[far], -1.0, 1.0))))
    axis = "[" + ", ".join(f"{c:+.2f}" for c in grid[far]) + "]"
    return (f"their directions cover {100 * coverage(e):.0f} % of the sphere, and none comes within {gap:.0f} deg "
            f"of {axis} in the {sensor}'s axes")

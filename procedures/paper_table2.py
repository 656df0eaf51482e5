"""Zhang et al. 2015, Table II / Figs. 5-6: gyroscope H error vs iterations, UKF against an optimizer.

Setting (from the brief): gyroscope, 10 table orientations (9 moves), rate noise 0.05 rad/s. The
paper's numbers could not be retrieved here, so `published` is None and the protocol below is our
reconstruction: a two-axis tumble table R = Rx(outer) Rz(inner) visits 10 random orientations with
trapezoidal moves (30-90 deg/s) sampled at 100 Hz; the true H is nominal (I + E) with E ~ N(0, 0.02);
both estimators start from the nominal H. "Iteration" is one pass over all moves for the UKF and
one cost evaluation (`max_nfev`) for the trust-region optimizer; every UKF pass here uses all
samples (no coarse first pass). The UKF's measurement noise is the
angle random walk of the rate noise over the mean move (it knows the noise, as in the paper's
simulation). The error is the relative
Frobenius norm |H_est - H_true| / |H_true|.
The paper's "noise variance 0.05 rad/s" is read as a standard deviation of 0.05 rad/s per sample.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from fixtures.motion import TableTrack
from rig.calibration.turntable.gyro import calibrate_gyro_ukf
from rig.calibration.turntable.gyro_baselines import calibrate_gyro_trust_region
from rig.rotations import TableGeometry
from rig.session_data import MoveStream

ITERATIONS = (2, 5, 10, 15, 20, 30, 50)
NOMINAL_COUNTS_PER_RAD_S = 939.65   # 16.4 LSB per deg/s, a +-2000 deg/s MEMS range


def random_gyro_truth(rng: np.random.Generator, misalign_std: float = 0.02,
                      counts_per_rad_s: float = NOMINAL_COUNTS_PER_RAD_S) -> tuple[np.ndarray, np.ndarray]:
    """(H, B): H = (I + E) / k with E ~ N(0, misalign_std) and B ~ U(-50, 50) counts."""
    H = (np.eye(3) + rng.normal(0.0, misalign_std, (3, 3))) / counts_per_rad_s
    return H, rng.uniform(-50.0, 50.0, 3)


def simulate_gyro_moves(rng: np.random.Generator, H: np.ndarray, B: np.ndarray, *, orientations: int = 20,
                        noise_rad_s: float = 0.0, rate_hz: float = 100.0, hold_s: float = 1.0,
                        geometry: TableGeometry | None = None) -> tuple[list[MoveStream], np.ndarray]:
    """Raw gyro moves between random orientations of a two-axis tumble table.

    Both axes move at once on trapezoidal profiles (speed 30-90 deg/s, 150 deg/s^2); the body
    rate comes from the table kinematics, raw counts are `H^-1 (omega + noise) + B`. Returns the
    moves and the hold means (raw, noise-free rate zero) for the bias.
    """
    geometry = geometry or TableGeometry()
    angles = np.column_stack([rng.uniform(-170, 170, orientations), rng.uniform(-180, 180, orientations)])
    track = TableTrack(*angles[0])
    t_marks, t_now = [], hold_s
    for a in angles[1:]:
        speed = rng.uniform(30.0, 90.0, 2)
        ends = [track.axes[k].move_to(t_now, float(a[k]), float(speed[k]), 150.0) for k in range(2)]
        t_marks.append((t_now, max(ends)))
        t_now = max(ends) + hold_s
    t = np.arange(0.0, t_now + 1.0 / rate_hz, 1.0 / rate_hz)
    pos, rate, _ = track.angles(t)
    omega = geometry.body_rate(pos[:, 0], pos[:, 1], rate[:, 0], rate[:, 1])
    omega = omega + rng.normal(0.0, noise_rad_s, omega.shape) if noise_rad_s > 0 else omega
    y = (omega @ np.linalg.inv(H).T) + B
    moves, hold_means = [], []
    for j, (t0, t1) in enumerate(t_marks):
        i0, i1 = int(np.searchsorted(t, t0, "right")) - 1, int(np.searchsorted(t, t1, "left"))
        moves.append(MoveStream(j, t[i0:i1 + 1], y[i0:i1 + 1], geometry.rotation(*angles[j]),
                                geometry.rotation(*angles[j + 1])))
    for t0, t1 in zip([0.0] + [m[1] for m in t_marks], [m[0] for m in t_marks] + [t[-1]]):
        sel = (t > t0 + 0.05) & (t < t1 - 0.05)
        if sel.any():
            hold_means.append(y[sel].mean(axis=0))
    return moves, np.array(hold_means)


def move_angle_noise(moves: list[MoveStream], noise_rad_s: float) -> float:
    """Angle random walk of white rate noise over the mean move: sigma * sqrt(dt * T) (the UKF's R)."""
    dt = float(np.median(np.concatenate([np.diff(m.t) for m in moves])))
    T = float(np.mean([m.t[-1] - m.t[0] for m in moves]))
    return max(noise_rad_s * np.sqrt(dt * T), 1e-6)


def _rel_err(H: np.ndarray, H_true: np.ndarray) -> float:
    return float(np.linalg.norm(H - H_true) / np.linalg.norm(H_true))


def run_table2(runs: int = 20, seed: int = 0, *, orientations: int = 10, noise_rad_s: float = 0.05,
               iterations: tuple[int, ...] = ITERATIONS) -> dict:
    """Monte Carlo of Table II: mean and std of the relative H error per iteration count."""
    rng = np.random.default_rng(seed)
    ukf_err = np.zeros((runs, len(iterations)))
    opt_err = np.zeros((runs, len(iterations)))
    for r in range(runs):
        H_true, B = random_gyro_truth(rng)
        moves, _ = simulate_gyro_moves(rng, H_true, B, orientations=orientations, noise_rad_s=noise_rad_s)
        H0 = np.eye(3) / NOMINAL_COUNTS_PER_RAD_S
        hist: list[np.ndarray] = []
        calibrate_gyro_ukf(moves, B, H0=H0, noise_rad=move_angle_noise(moves, noise_rad_s), max_passes=max(iterations),
                           tol=0.0, first_pass_stride=1, history=hist)
        ukf_err[r] = [_rel_err(hist[min(k, len(hist)) - 1], H_true) for k in iterations]
        for c, k in enumerate(iterations):
            opt = calibrate_gyro_trust_region(moves, B, H0=H0, max_nfev=k)
            opt_err[r, c] = _rel_err(opt.H, H_true)
    rows = [{"iteration": k,
             "ukf_mean_pct": 100 * float(ukf_err[:, c].mean()), "ukf_std_pct": 100 * float(ukf_err[:, c].std(ddof=1)),
             "optimizer_mean_pct": 100 * float(opt_err[:, c].mean()),
             "optimizer_std_pct": 100 * float(opt_err[:, c].std(ddof=1))}
            for c, k in enumerate(iterations)]
    return {"table": "Zhang 2015 Table II (reconstructed protocol)", "sensor": "gyro", "orientations": orientations,
            "noise_rad_s": noise_rad_s, "runs": runs, "seed": seed, "error": "relative Frobenius |H-H_true|/|H_true|",
            "rows": rows, "published": None,
            "published_note": "paper text not retrievable in this environment; no published rows to compare"}


def plot_table2(result: dict, out_dir: str | Path) -> list[Path]:
    """Figs. 5-6 style PNGs: mean error vs iterations (log y) and its spread, UKF vs optimizer."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    it = [r["iteration"] for r in result["rows"]]
    paths = []
    for key, label, name in (("mean", "mean error (%)", "fig5_gyro_error_mean.png"),
                             ("std", "std of error (%)", "fig6_gyro_error_std.png")):
        fig, ax = plt.subplots(figsize=(5, 3.5))
        ax.semilogy(it, [r[f"ukf_{key}_pct"] for r in result["rows"]], "o-", label="UKF (ours)")
        ax.semilogy(it, [r[f"optimizer_{key}_pct"] for r in result["rows"]], "s--", label="trust region")
        ax.set_xlabel("iterations")
        ax.set_ylabel(f"gyro H {label}")
        ax.set_title(f"{result['orientations']} orientations, noise {result['noise_rad_s']} rad/s, "
                     f"{result['runs']} runs")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
        fig.tight_layout()
        fig.savefig(out / name, dpi=120)
        plt.close(fig)
        paths.append(out / name)
    return paths


if __name__ == "__main__":
    print(json.dumps(run_table2(), indent=2))

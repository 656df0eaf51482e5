"""The per-sample loop of the quaternion UKF, in plain Python floats.

Why not numpy per step: the matrices are 3x3 and 4x4, where one numpy call (2-15 us) costs more than
the arithmetic; the unrolled scalar step takes ~10-20 us. The innovation covariance is factored by an
explicit Cholesky and the gain applied by whitening (W = Pxz L^-T, v = L^-1 nu: d = W v, P -= W W^T).
Everything that does not depend on the state is vectorised beforehand (`measurements.prepare`).
`reference.py` runs the same filter through filterpy's `UnscentedKalmanFilter`; the tests hold the
two to agree.

State: the mean quaternion q (fixture -> navigation) and the 3x3 covariance P of the error rotation
vector `d`, with `q_true = q * Exp(d)`. Sigma points `d_i = +-c L_j` (L = chol(P), c = sqrt(n + lambda),
eqs. 23-25) are mapped to the measurement and recombined with the scaled-UT weights (eqs. 26-28).
The sigma points come in +- pairs, which the algebra below uses: for `v_i = Exp(-d_i) v` the pair
shares `sym = v cos + (1 - cos)(k.v) k` and differs by `-+ anti = -+ sin (k x v)`.
"""

from __future__ import annotations

import math

_TWO_PI = 2.0 * math.pi


def _wrap(a: float) -> float:
    return (a + math.pi) % _TWO_PI - math.pi


def _pair_terms(d: tuple, v: tuple) -> tuple:
    """sym and anti of a sigma pair +-d applied to body vector v (see module docstring)."""
    dx, dy, dz = d
    vx, vy, vz = v
    th = math.sqrt(dx * dx + dy * dy + dz * dz)
    if th < 1e-15:
        return (vx, vy, vz), (0.0, 0.0, 0.0)
    kx, ky, kz = dx / th, dy / th, dz / th
    cs, sn = math.cos(th), math.sin(th)
    f = (1.0 - cs) * (kx * vx + ky * vy + kz * vz)
    return ((vx * cs + f * kx, vy * cs + f * ky, vz * cs + f * kz),
            (sn * (ky * vz - kz * vy), sn * (kz * vx - kx * vz), sn * (kx * vy - ky * vx)))


def vector_update(q: tuple, P: tuple, meas: tuple, var: float, v_nav: tuple, c: float, wm0: float, wc0: float,
                  wi: float) -> tuple[tuple, tuple]:
    """One UT update (eqs. 23-28) with a unit vector measured in the body frame, `meas ~ R^T v_nav`.

    Used for the gravity direction and, in the 'vector' measurement mode, the field direction.
    """
    qw, qx, qy, qz = q
    p11, p12, p13, p22, p23, p33 = P
    sqrt, sin, cos = math.sqrt, math.sin, math.cos
    w2 = 2.0 * wi
    l11 = sqrt(p11)
    l21, l31 = p12 / l11, p13 / l11
    l22 = sqrt(p22 - l21 * l21)
    l32 = (p23 - l31 * l21) / l22
    l33 = sqrt(p33 - l31 * l31 - l32 * l32)
    c1, c2, c3, c5, c6, c9 = c * l11, c * l21, c * l31, c * l22, c * l32, c * l33
    cols = ((c1, c2, c3), (0.0, c5, c6), (0.0, 0.0, c9))
    vx, vy, vz = v_nav
    # R^T v_nav: rows of R weighted by v_nav
    r1 = (1.0 - 2.0 * (qy * qy + qz * qz), 2.0 * (qx * qy - qw * qz), 2.0 * (qx * qz + qw * qy))
    r2 = (2.0 * (qx * qy + qw * qz), 1.0 - 2.0 * (qx * qx + qz * qz), 2.0 * (qy * qz - qw * qx))
    r3 = (2.0 * (qx * qz - qw * qy), 2.0 * (qy * qz + qw * qx), 1.0 - 2.0 * (qx * qx + qy * qy))
    g = (vx * r1[0] + vy * r2[0] + vz * r3[0], vx * r1[1] + vy * r2[1] + vz * r3[1],
         vx * r1[2] + vy * r2[2] + vz * r3[2])
    gx, gy, gz = g
    terms = []
    for dx, dy, dz in cols:                       # _pair_terms, inlined: this is the hot loop
        th = sqrt(dx * dx + dy * dy + dz * dz)
        it = 1.0 / th
        kx, ky, kz = dx * it, dy * it, dz * it
        cs, sn = cos(th), sin(th)
        f = (1.0 - cs) * (kx * gx + ky * gy + kz * gz)
        terms.append((gx * cs + f * kx, gy * cs + f * ky, gz * cs + f * kz,
                      sn * (ky * gz - kz * gy), sn * (kz * gx - kx * gz), sn * (kx * gy - ky * gx)))
    (s1x, s1y, s1z, a1x, a1y, a1z), (s2x, s2y, s2z, a2x, a2y, a2z), (s3x, s3y, s3z, a3x, a3y, a3z) = terms
    zx = wm0 * gx + w2 * (s1x + s2x + s3x)
    zy = wm0 * gy + w2 * (s1y + s2y + s3y)
    zz = wm0 * gz + w2 * (s1z + s2z + s3z)
    e0x, e0y, e0z = gx - zx, gy - zy, gz - zz
    s1x, s1y, s1z, s2x, s2y, s2z = s1x - zx, s1y - zy, s1z - zz, s2x - zx, s2y - zy, s2z - zz
    s3x, s3y, s3z = s3x - zx, s3y - zy, s3z - zz
    s11 = wc0 * e0x * e0x + var + w2 * (s1x * s1x + a1x * a1x + s2x * s2x + a2x * a2x + s3x * s3x + a3x * a3x)
    s12 = wc0 * e0x * e0y + w2 * (s1x * s1y + a1x * a1y + s2x * s2y + a2x * a2y + s3x * s3y + a3x * a3y)
    s13 = wc0 * e0x * e0z + w2 * (s1x * s1z + a1x * a1z + s2x * s2z + a2x * a2z + s3x * s3z + a3x * a3z)
    s22 = wc0 * e0y * e0y + var + w2 * (s1y * s1y + a1y * a1y + s2y * s2y + a2y * a2y + s3y * s3y + a3y * a3y)
    s23 = wc0 * e0y * e0z + w2 * (s1y * s1z + a1y * a1z + s2y * s2z + a2y * a2z + s3y * s3z + a3y * a3z)
    s33 = wc0 * e0z * e0z + var + w2 * (s1z * s1z + a1z * a1z + s2z * s2z + a2z * a2z + s3z * s3z + a3z * a3z)
    m2 = -w2
    x11, x12, x13 = m2 * c1 * a1x, m2 * c1 * a1y, m2 * c1 * a1z
    x21, x22, x23 = m2 * (c2 * a1x + c5 * a2x), m2 * (c2 * a1y + c5 * a2y), m2 * (c2 * a1z + c5 * a2z)
    x31 = m2 * (c3 * a1x + c6 * a2x + c9 * a3x)
    x32 = m2 * (c3 * a1y + c6 * a2y + c9 * a3y)
    x33 = m2 * (c3 * a1z + c6 * a2z + c9 * a3z)
    L11 = sqrt(s11)
    i11 = 1.0 / L11
    L21, L31 = s12 * i11, s13 * i11
    L22 = sqrt(s22 - L21 * L21)
    i22 = 1.0 / L22
    L32 = (s23 - L31 * L21) * i22
    i33 = 1.0 / sqrt(s33 - L31 * L31 - L32 * L32)
    out = []
    for b1, b2, b3 in ((meas[0] - zx, meas[1] - zy, meas[2] - zz), (x11, x12, x13), (x21, x22, x23),
                       (x31, x32, x33)):
        y1 = b1 * i11
        y2 = (b2 - L21 * y1) * i22
        out.append((y1, y2, (b3 - L31 * y1 - L32 * y2) * i33))
    (v1, v2, v3), (w11, w12, w13), (w21, w22, w23), (w31, w32, w33) = out
    u0 = w11 * v1 + w12 * v2 + w13 * v3
    u1 = w21 * v1 + w22 * v2 + w23 * v3
    u2 = w31 * v1 + w32 * v2 + w33 * v3
    P = (p11 - (w11 * w11 + w12 * w12 + w13 * w13), p12 - (w11 * w21 + w12 * w22 + w13 * w23),
         p13 - (w11 * w31 + w12 * w32 + w13 * w33), p22 - (w21 * w21 + w22 * w22 + w23 * w23),
         p23 - (w21 * w31 + w22 * w32 + w23 * w33), p33 - (w31 * w31 + w32 * w32 + w33 * w33))
    th = sqrt(u0 * u0 + u1 * u1 + u2 * u2)
    k = 0.5 - th * th / 48.0 if th < 1e-4 else sin(0.5 * th) / th
    ew = cos(0.5 * th)
    u0, u1, u2 = k * u0, k * u1, k * u2
    return (qw * ew - qx * u0 - qy * u1 - qz * u2, qw * u0 + qx * ew + qy * u2 - qz * u1,
            qw * u1 - qx * u2 + qy * ew + qz * u0, qw * u2 + qx * u1 - qy * u0 + qz * ew), P


def run(q0: tuple, P0: tuple, steps, c: float, wm0: float, wc0: float, wi: float, field_nav: tuple | None = None):
    """Filter the prepared steps; returns (quaternions, covariance diagonals, accel updates, mag updates).

    steps: iterable of (dq, A, q_var, up, up_var, mag, mag_var) with up/mag None when unusable.
    Heading mode (field_nav None): mag is the unit horizontal field, mag_var the heading variance, and
    gravity and heading form one 4-D update. Vector mode: mag is the unit field direction, compared
    with R^T field_nav in a second, sequential 3-D update after the gravity one.
    q0: (w, x, y, z); P0: (p11, p12, p13, p22, p23, p33).
    """
    qw, qx, qy, qz = q0
    p11, p12, p13, p22, p23, p33 = P0
    sqrt, atan2, cos, sin = math.sqrt, math.atan2, math.cos, math.sin
    quats, diag = [], []
    w2 = 2.0 * wi
    n_acc = n_mag = 0
    for dq, A, qv, up, up_var, north, h_var in steps:
        # ---- time update (eqs. 7-8, 13, 16): q <- q dq; P <- A P A^T + Q (the UT of a rotation is exact)
        dw, dx, dy, dz = dq
        qw, qx, qy, qz = (qw * dw - qx * dx - qy * dy - qz * dz, qw * dx + qx * dw + qy * dz - qz * dy,
                          qw * dy - qx * dz + qy * dw + qz * dx, qw * dz + qx * dy - qy * dx + qz * dw)
        a11, a12, a13, a21, a22, a23, a31, a32, a33 = A
        m11 = a11 * p11 + a12 * p12 + a13 * p13
        m12 = a11 * p12 + a12 * p22 + a13 * p23
        m13 = a11 * p13 + a12 * p23 + a13 * p33
        m21 = a21 * p11 + a22 * p12 + a23 * p13
        m22 = a21 * p12 + a22 * p22 + a23 * p23
        m23 = a21 * p13 + a22 * p23 + a23 * p33
        m31 = a31 * p11 + a32 * p12 + a33 * p13
        m32 = a31 * p12 + a32 * p22 + a33 * p23
        m33 = a31 * p13 + a32 * p23 + a33 * p33
        p11 = m11 * a11 + m12 * a12 + m13 * a13 + qv
        p12 = m11 * a21 + m12 * a22 + m13 * a23
        p13 = m11 * a31 + m12 * a32 + m13 * a33
        p22 = m21 * a21 + m22 * a22 + m23 * a23 + qv
        p23 = m21 * a31 + m22 * a32 + m23 * a33
        p33 = m31 * a31 + m32 * a32 + m33 * a33 + qv

        if field_nav is not None:
            if up is not None:
                (qw, qx, qy, qz), (p11, p12, p13, p22, p23, p33) = vector_update(
                    (qw, qx, qy, qz), (p11, p12, p13, p22, p23, p33), up, up_var, (0.0, 0.0, 1.0), c, wm0, wc0, wi)
                n_acc += 1
                if north is not None:
                    (qw, qx, qy, qz), (p11, p12, p13, p22, p23, p33) = vector_update(
                        (qw, qx, qy, qz), (p11, p12, p13, p22, p23, p33), north, h_var, field_nav, c, wm0, wc0, wi)
                    n_mag += 1
        elif up is not None:
            # ---- sigma points (eqs. 23-25) around the mean: columns of c chol(P)
            l11 = sqrt(p11)
            l21, l31 = p12 / l11, p13 / l11
            l22 = sqrt(p22 - l21 * l21)
            l32 = (p23 - l31 * l21) / l22
            l33 = sqrt(p33 - l31 * l31 - l32 * l32)
            cols = ((c * l11, c * l21, c * l31), (0.0, c * l22, c * l32), (0.0, 0.0, c * l33))
            # predicted gravity direction in the body frame at the mean: R^T e_z (row 3 of R)
            g = (2.0 * (qx * qz - qw * qy), 2.0 * (qy * qz + qw * qx), 1.0 - 2.0 * (qx * qx + qy * qy))
            g_pairs = [_pair_terms(d, g) for d in cols]
            zx = wm0 * g[0] + 2.0 * wi * (g_pairs[0][0][0] + g_pairs[1][0][0] + g_pairs[2][0][0])
            zy = wm0 * g[1] + 2.0 * wi * (g_pairs[0][0][1] + g_pairs[1][0][1] + g_pairs[2][0][1])
            zz = wm0 * g[2] + 2.0 * wi * (g_pairs[0][0][2] + g_pairs[1][0][2] + g_pairs[2][0][2])
            # residuals: centre e0; pair j: (s - a), (s + a)
            e0x, e0y, e0z = g[0] - zx, g[1] - zy, g[2] - zz
            # accel block of the innovation covariance: pair j contributes 2 wi (s s^T + a a^T)
            s11 = wc0 * e0x * e0x + up_var
            s12 = wc0 * e0x * e0y
            s13 = wc0 * e0x * e0z
            s22 = wc0 * e0y * e0y + up_var
            s23 = wc0 * e0y * e0z
            s33 = wc0 * e0z * e0z + up_var
            dev_s = []
            for (s, a) in g_pairs:
                sx, sy, sz = s[0] - zx, s[1] - zy, s[2] - zz
                ax, ay, az = a
                dev_s.append((sx, sy, sz))
                s11 += w2 * (sx * sx + ax * ax)
                s12 += w2 * (sx * sy + ax * ay)
                s13 += w2 * (sx * sz + ax * az)
                s22 += w2 * (sy * sy + ay * ay)
                s23 += w2 * (sy * sz + ay * az)
                s33 += w2 * (sz * sz + az * az)
            # cross covariance, accel block: -2 wi sum_j col_j a_j^T (col_j has leading zeros)
            (c1, c2, c3), (_, c5, c6), (_, _, c9) = cols
            (a1x, a1y, a1z), (a2x, a2y, a2z), (a3x, a3y, a3z) = g_pairs[0][1], g_pairs[1][1], g_pairs[2][1]
            x11, x12, x13 = -w2 * c1 * a1x, -w2 * c1 * a1y, -w2 * c1 * a1z
            x21 = -w2 * (c2 * a1x + c5 * a2x)
            x22 = -w2 * (c2 * a1y + c5 * a2y)
            x23 = -w2 * (c2 * a1z + c5 * a2z)
            x31 = -w2 * (c3 * a1x + c6 * a2x + c9 * a3x)
            x32 = -w2 * (c3 * a1y + c6 * a2y + c9 * a3y)
            x33 = -w2 * (c3 * a1z + c6 * a2z + c9 * a3z)
            n1, n2, n3 = up[0] - zx, up[1] - zy, up[2] - zz
            if north is not None:
                # heading (eqs. 5, 14 in vector form): angle about the measured up from the measured
                # horizontal field to the sigma point's predicted field direction R^T e_y
                mx, my, mz = north
                ex, ey, ez = up[1] * mz - up[2] * my, up[2] * mx - up[0] * mz, up[0] * my - up[1] * mx
                nb = (2.0 * (qx * qy + qw * qz), 1.0 - 2.0 * (qx * qx + qz * qz), 2.0 * (qy * qz - qw * qx))
                psi0 = atan2(ex * nb[0] + ey * nb[1] + ez * nb[2], mx * nb[0] + my * nb[1] + mz * nb[2])
                dps = []
                for d in cols:
                    (p0, p1, p2), (b0, b1, b2) = _pair_terms(d, nb)
                    dp = _wrap(atan2(ex * (p0 - b0) + ey * (p1 - b1) + ez * (p2 - b2),
                                     mx * (p0 - b0) + my * (p1 - b1) + mz * (p2 - b2)) - psi0)
                    dm = _wrap(atan2(ex * (p0 + b0) + ey * (p1 + b1) + ez * (p2 + b2),
                                     mx * (p0 + b0) + my * (p1 + b1) + mz * (p2 + b2)) - psi0)
                    dps.append((dp, dm))
                shift = wi * sum(dp + dm for dp, dm in dps)
                s44 = wc0 * shift * shift + h_var
                s14, s24, s34 = -wc0 * shift * e0x, -wc0 * shift * e0y, -wc0 * shift * e0z
                for (dp, dm), (sx, sy, sz), (_, a) in zip(dps, dev_s, g_pairs):
                    s44 += wi * ((dp - shift) ** 2 + (dm - shift) ** 2)
                    f, h = wi * (dp + dm - 2.0 * shift), wi * (dm - dp)
                    s14 += f * sx + h * a[0]
                    s24 += f * sy + h * a[1]
                    s34 += f * sz + h * a[2]
                h1, h2, h3 = wi * (dps[0][0] - dps[0][1]), wi * (dps[1][0] - dps[1][1]), wi * (dps[2][0] - dps[2][1])
                x14 = c1 * h1
                x24 = c2 * h1 + c5 * h2
                x34 = c3 * h1 + c6 * h2 + c9 * h3
                n4 = -_wrap(psi0 + shift)
                n_mag += 1
            else:
                # no heading: a decoupled dummy row (zero innovation, zero cross covariance) changes nothing
                s14 = s24 = s34 = x14 = x24 = x34 = n4 = 0.0
                s44 = 1.0
            # ---- gain by whitening with L = chol(S): W = Pxz L^-T, v = L^-1 nu; d = W v, P -= W W^T
            L11 = sqrt(s11)
            i11 = 1.0 / L11
            L21, L31, L41 = s12 * i11, s13 * i11, s14 * i11
            L22 = sqrt(s22 - L21 * L21)
            i22 = 1.0 / L22
            L32 = (s23 - L31 * L21) * i22
            L42 = (s24 - L41 * L21) * i22
            L33 = sqrt(s33 - L31 * L31 - L32 * L32)
            i33 = 1.0 / L33
            L43 = (s34 - L41 * L31 - L42 * L32) * i33
            i44 = 1.0 / sqrt(s44 - L41 * L41 - L42 * L42 - L43 * L43)
            out = []
            for b1, b2, b3, b4 in ((n1, n2, n3, n4), (x11, x12, x13, x14), (x21, x22, x23, x24),
                                   (x31, x32, x33, x34)):
                y1 = b1 * i11
                y2 = (b2 - L21 * y1) * i22
                y3 = (b3 - L31 * y1 - L32 * y2) * i33
                y4 = (b4 - L41 * y1 - L42 * y2 - L43 * y3) * i44
                out.append((y1, y2, y3, y4))
            (v1, v2, v3, v4), (w11, w12, w13, w14), (w21, w22, w23, w24), (w31, w32, w33, w34) = out
            u0 = w11 * v1 + w12 * v2 + w13 * v3 + w14 * v4
            u1 = w21 * v1 + w22 * v2 + w23 * v3 + w24 * v4
            u2 = w31 * v1 + w32 * v2 + w33 * v3 + w34 * v4
            p11 -= w11 * w11 + w12 * w12 + w13 * w13 + w14 * w14
            p12 -= w11 * w21 + w12 * w22 + w13 * w23 + w14 * w24
            p13 -= w11 * w31 + w12 * w32 + w13 * w33 + w14 * w34
            p22 -= w21 * w21 + w22 * w22 + w23 * w23 + w24 * w24
            p23 -= w21 * w31 + w22 * w32 + w23 * w33 + w24 * w34
            p33 -= w31 * w31 + w32 * w32 + w33 * w33 + w34 * w34
            # ---- reset: q <- q Exp(d_hat)
            th = sqrt(u0 * u0 + u1 * u1 + u2 * u2)
            k = 0.5 - th * th / 48.0 if th < 1e-4 else sin(0.5 * th) / th
            ew = cos(0.5 * th)
            u0, u1, u2 = k * u0, k * u1, k * u2
            qw, qx, qy, qz = (qw * ew - qx * u0 - qy * u1 - qz * u2, qw * u0 + qx * ew + qy * u2 - qz * u1,
                              qw * u1 - qx * u2 + qy * ew + qz * u0, qw * u2 + qx * u1 - qy * u0 + qz * ew)
            n_acc += 1
        nq = 1.0 / sqrt(qw * qw + qx * qx + qy * qy + qz * qz)
        qw, qx, qy, qz = qw * nq, qx * nq, qy * nq, qz * nq
        quats.append((qw, qx, qy, qz))
        diag.append((p11, p22, p33))
    return quats, diag, n_acc, n_mag

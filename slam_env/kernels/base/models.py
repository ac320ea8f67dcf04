"""The motion and measurement models of the seeds, once, as scalar compiled functions.

Every equation of the models lives here: the filter's kernels (:mod:`slam_env.kernels.ekf.filter`,
:mod:`slam_env.kernels.ekf.corrections`, :mod:`slam_env.kernels.ekf.new_landmarks`), the
odometry sensor's sampling and the public array functions of :mod:`slam_env.ekf.models`
all compute through these. Plain floats in, a tuple of floats out, no arrays and no
allocation, so that a kernel calling them in its loop costs only the arithmetic.

Conventions: a pose is ``(x, y, θ)``; a landmark ``(mx, my)``; the heading is wrapped
to [−π, π). The two motion models share the form of their pose Jacobian,
``G = [[1, 0, a], [0, 1, b], [0, 0, 1]]`` (the heading enters the position only,
nothing enters the heading), so a prediction is described by ``(a, b)`` and the upper
triangle ``(r00, r01, r02, r11, r12, r22)`` of its noise ``R_x``. A measurement's
Jacobian is given by the two non-zero rows of the full-width H restricted to the pose
and landmark columns, ``[H_x | H_m]`` (2×5); the inverse model's
``L = ∂h⁻¹/∂pose = [[1, 0, l02], [0, 1, l12]]`` by ``(l02, l12)`` and
``W = ∂h⁻¹/∂z`` by its four entries.
"""

from __future__ import annotations

import math

import numpy as np

from slam_env.kernels.base.angles import wrap as wrap_angle
from slam_env.kernels.base.compiling import kernel

# Model codes, as the kernels take them.
ODOMETRY, VELOCITY = 0, 1
RANGE_BEARING, CARTESIAN = 0, 1


# --------------------------------------------------------------------------- odometry (seed 000)

# Below this translation (m) the odometry reading's direction of motion is noise: a contact
# nudging a robot that turns in place would otherwise give any δrot1 up to ±π/2 and,
# through α1·δrot1², a heading noise of tenths of a radian for a sub-millimetre push. The
# reading then keeps the displacement along the heading and drops the sideways part.
MIN_ODOMETRY_TRANSLATION = 1e-3
# The variance (m²) of that dropped sideways part, at most MIN_ODOMETRY_TRANSLATION each
# way (a uniform spread's a²/3), which the prediction adds to each position axis: without
# it a turn on the spot from a known pose predicts a sideways variance of ~1e-13 m² and
# one sub-millimetre nudge gives a NEES of 1e10.
DROPPED_SIDEWAYS_VARIANCE = MIN_ODOMETRY_TRANSLATION * MIN_ODOMETRY_TRANSLATION / 3.0


@kernel
def odometry_variances(
    rot1: float, trans: float, rot2: float, a1: float, a2: float, a3: float, a4: float
) -> tuple[float, float, float]:
    """The diagonal of M, the action-space noise of u = (δrot1, δtr, δrot2):
    (α1·δrot1² + α2·δtr², α3·δtr² + α4·(δrot1² + δrot2²), α1·δrot2² + α2·δtr²)."""
    r1 = rot1 * rot1
    t = trans * trans
    r2 = rot2 * rot2
    return a1 * r1 + a2 * t, a3 * t + a4 * (r1 + r2), a1 * r2 + a2 * t


@kernel
def odometry_motion(
    x: float, y: float, th: float, rot1: float, trans: float, rot2: float
) -> tuple[float, float, float]:
    """g(pose, u): x += δtr·cos(θ+δrot1), y += δtr·sin(θ+δrot1), θ = wrap(θ+δrot1+δrot2)."""
    h = th + rot1
    return x + trans * math.cos(h), y + trans * math.sin(h), wrap_angle(h + rot2)


@kernel
def odometry_jacobian(th: float, rot1: float, trans: float) -> tuple[float, float, float, float]:
    """``(a, b, c, s)``: G = ∂g/∂pose = [[1, 0, a], [0, 1, b], [0, 0, 1]] and
    V = ∂g/∂u = [[a, c, 0], [b, s, 0], [1, 0, 1]] with c, s = cos, sin(θ+δrot1),
    a = −δtr·s, b = δtr·c."""
    h = th + rot1
    c = math.cos(h)
    s = math.sin(h)
    return -trans * s, trans * c, c, s


@kernel
def odometry_predict(
    x: float,
    y: float,
    th: float,
    rot1: float,
    trans: float,
    rot2: float,
    a1: float,
    a2: float,
    a3: float,
    a4: float,
) -> tuple[float, float, float, float, float, float, float, float, float, float, float]:
    """``(x', y', θ', a, b, r00, r01, r02, r11, r12, r22)``: the next pose, G by (a, b)
    and the upper triangle of R_x = V M Vᵀ + m0·m1·n nᵀ + σd²·I₂ (position block).

    Seed 000's V M Vᵀ gives the sideways direction n = (−sin, cos)(θ + δrot1) the
    variance δtr²·m0, which vanishes with δtr however noisy δtr is: the product of the
    noises of δtr and δrot1 moves the robot sideways by var(δtr)·var(δrot1) = m0·m1 in
    variance (the Gaussian second-order term of g's δtr·δrot1 product, the one that
    survives δtr → 0). σd² is :data:`DROPPED_SIDEWAYS_VARIANCE`, for the sideways part
    of a sub-millimetre motion that the reading drops."""
    nx, ny, nth = odometry_motion(x, y, th, rot1, trans, rot2)
    a, b, c, s = odometry_jacobian(th, rot1, trans)
    m0, m1, m2 = odometry_variances(rot1, trans, rot2, a1, a2, a3, a4)
    sideways = m0 * m1
    return (
        nx,
        ny,
        nth,
        a,
        b,
        a * a * m0 + c * c * m1 + s * s * sideways + DROPPED_SIDEWAYS_VARIANCE,
        a * b * m0 + c * s * m1 - c * s * sideways,
        a * m0,
        b * b * m0 + s * s * m1 + c * c * sideways + DROPPED_SIDEWAYS_VARIANCE,
        b * m0,
        m0 + m2,
    )


# --------------------------------------------------------------------------- velocity (seed 004)


@kernel
def velocity_variances(
    dp: float, dth: float, sp: float, sth: float, bp: float, bth: float
) -> tuple[float, float]:
    """The diagonal of Σu for u = (Δp, Δθ): (σp² + βp·Δp², σθ² + βθ·Δθ²)."""
    return sp * sp + bp * dp * dp, sth * sth + bth * dth * dth


@kernel
def velocity_motion(
    x: float, y: float, th: float, dp: float, dth: float
) -> tuple[float, float, float]:
    """f(pose, u), translation then rotation: x += Δp·cos θ, y += Δp·sin θ, θ = wrap(θ + Δθ)."""
    return x + dp * math.cos(th), y + dp * math.sin(th), wrap_angle(th + dth)


@kernel
def velocity_jacobian(th: float, dp: float) -> tuple[float, float, float, float]:
    """``(a, b, c, s)``: A = ∂f/∂pose = [[1, 0, a], [0, 1, b], [0, 0, 1]] and
    B = ∂f/∂u = [[c, 0], [s, 0], [0, 1]] with c, s = cos, sin θ, a = −Δp·s, b = Δp·c."""
    c = math.cos(th)
    s = math.sin(th)
    return -dp * s, dp * c, c, s


@kernel
def velocity_predict(
    x: float,
    y: float,
    th: float,
    dp: float,
    dth: float,
    sp: float,
    sth: float,
    bp: float,
    bth: float,
) -> tuple[float, float, float, float, float, float, float, float, float, float, float]:
    """``(x', y', θ', a, b, r00, r01, r02, r11, r12, r22)``: the next pose, A by (a, b)
    and the upper triangle of R_x = B Σu Bᵀ."""
    nx, ny, nth = velocity_motion(x, y, th, dp, dth)
    a, b, c, s = velocity_jacobian(th, dp)
    v0, v1 = velocity_variances(dp, dth, sp, sth, bp, bth)
    return nx, ny, nth, a, b, c * c * v0, c * s * v0, 0.0, s * s * v0, 0.0, v1


@kernel
def motion_predict(
    model: int,
    x: float,
    y: float,
    th: float,
    u0: float,
    u1: float,
    u2: float,
    p0: float,
    p1: float,
    p2: float,
    p3: float,
) -> tuple[float, float, float, float, float, float, float, float, float, float, float]:
    """The prediction of motion model ``model`` (:data:`ODOMETRY`: u = (δrot1, δtr,
    δrot2), params α1..α4; :data:`VELOCITY`: u = (Δp, Δθ), u2 unused, params σp, σθ,
    βp, βθ)."""
    if model == ODOMETRY:
        return odometry_predict(x, y, th, u0, u1, u2, p0, p1, p2, p3)
    return velocity_predict(x, y, th, u0, u1, p0, p1, p2, p3)


# ------------------------------------------------------------------------ range-bearing (seed 000)


@kernel
def range_bearing_observe(
    x: float, y: float, th: float, mx: float, my: float
) -> tuple[float, float]:
    """z = h(pose, m) = (r, φ): r = √q, φ = wrap(atan2(dy, dx) − θ), (dx, dy) = m − t,
    q = dx² + dy²."""
    dx = mx - x
    dy = my - y
    return math.sqrt(dx * dx + dy * dy), wrap_angle(math.atan2(dy, dx) - th)


@kernel
def range_bearing_jacobian(
    x: float, y: float, th: float, mx: float, my: float
) -> tuple[float, float, float, float, float, float, float, float, float, float]:
    """The rows of [H_x | H_m] (seed 000 §2.3): (−dx/√q, −dy/√q, 0, dx/√q, dy/√q) and
    (dy/q, −dx/q, −1, −dy/q, dx/q). Undefined at q = 0 (the landmark on the robot,
    see :func:`range_bearing_singular`): all NaN there."""
    dx = mx - x
    dy = my - y
    q = dx * dx + dy * dy
    if q == 0.0:
        nan = math.nan
        return nan, nan, nan, nan, nan, nan, nan, nan, nan, nan
    r = math.sqrt(q)
    a = dx / r
    b = dy / r
    c = dy / q
    d = dx / q
    return -a, -b, 0.0, a, b, c, -d, -1.0, -c, d


@kernel
def range_bearing_singular(x: float, y: float, mx: float, my: float) -> bool:
    """Whether h cannot be linearised: the landmark on the robot (q = 0)."""
    return mx == x and my == y


@kernel
def range_bearing_inverse(
    x: float, y: float, th: float, r: float, phi: float
) -> tuple[float, float]:
    """m = h⁻¹(z, pose) = t + r·(cos(φ + θ), sin(φ + θ)) (seed 000 §2.2)."""
    a = phi + th
    return x + r * math.cos(a), y + r * math.sin(a)


@kernel
def range_bearing_inverse_jacobian(
    th: float, r: float, phi: float
) -> tuple[float, float, float, float, float, float]:
    """``(l02, l12, w00, w01, w10, w11)``: L = [[1, 0, −r·sin(φ+θ)], [0, 1, r·cos(φ+θ)]],
    W = [[cos(φ+θ), −r·sin(φ+θ)], [sin(φ+θ), r·cos(φ+θ)]]."""
    a = phi + th
    c = math.cos(a)
    s = math.sin(a)
    return -r * s, r * c, c, -r * s, s, r * c


# --------------------------------------------------------------------------- cartesian (seed 004)


@kernel
def cartesian_observe(x: float, y: float, th: float, mx: float, my: float) -> tuple[float, float]:
    """z = R(θ)ᵀ (m − t), the landmark in the robot frame."""
    c = math.cos(th)
    s = math.sin(th)
    dx = mx - x
    dy = my - y
    return c * dx + s * dy, -s * dx + c * dy


@kernel
def cartesian_jacobian(
    x: float, y: float, th: float, mx: float, my: float
) -> tuple[float, float, float, float, float, float, float, float, float, float]:
    """The rows of [H_x | H_m] with (z1, z2) = h: (−cos θ, −sin θ, z2, cos θ, sin θ) and
    (sin θ, −cos θ, −z1, −sin θ, cos θ)."""
    z1, z2 = cartesian_observe(x, y, th, mx, my)
    c = math.cos(th)
    s = math.sin(th)
    return -c, -s, z2, c, s, s, -c, -z1, -s, c


@kernel
def cartesian_inverse(x: float, y: float, th: float, z1: float, z2: float) -> tuple[float, float]:
    """m = h⁻¹(z, pose) = t + R(θ)·z."""
    c = math.cos(th)
    s = math.sin(th)
    return x + c * z1 - s * z2, y + s * z1 + c * z2


@kernel
def cartesian_inverse_jacobian(
    th: float, z1: float, z2: float
) -> tuple[float, float, float, float, float, float]:
    """``(l02, l12, w00, w01, w10, w11)``: L = [[1, 0, −sin θ·z1 − cos θ·z2],
    [0, 1, cos θ·z1 − sin θ·z2]], W = R(θ)."""
    c = math.cos(th)
    s = math.sin(th)
    return -s * z1 - c * z2, c * z1 - s * z2, c, -s, s, c


# --------------------------------------------------------------------------- by model code


@kernel
def observe(model: int, x: float, y: float, th: float, mx: float, my: float) -> tuple[float, float]:
    """h of measurement model ``model`` (:data:`RANGE_BEARING` or :data:`CARTESIAN`)."""
    if model == RANGE_BEARING:
        return range_bearing_observe(x, y, th, mx, my)
    return cartesian_observe(x, y, th, mx, my)


@kernel
def jacobian(
    model: int, x: float, y: float, th: float, mx: float, my: float
) -> tuple[float, float, float, float, float, float, float, float, float, float]:
    """The rows of [H_x | H_m] of measurement model ``model``."""
    if model == RANGE_BEARING:
        return range_bearing_jacobian(x, y, th, mx, my)
    return cartesian_jacobian(x, y, th, mx, my)


@kernel
def singular(model: int, x: float, y: float, mx: float, my: float) -> bool:
    """Whether measurement model ``model`` cannot be linearised at this landmark
    (range-bearing: the landmark on the robot; the cartesian model never)."""
    if model == RANGE_BEARING:
        return range_bearing_singular(x, y, mx, my)
    return False


@kernel
def innovation(model: int, z0: float, z1: float, zh0: float, zh1: float) -> tuple[float, float]:
    """ν = z − ẑ, the bearing component of a range-bearing innovation wrapped to [−π, π)."""
    if model == RANGE_BEARING:
        return z0 - zh0, wrap_angle(z1 - zh1)
    return z0 - zh0, z1 - zh1


@kernel
def inverse(model: int, x: float, y: float, th: float, z0: float, z1: float) -> tuple[float, float]:
    """h⁻¹ of measurement model ``model``: the landmark a measurement z puts at."""
    if model == RANGE_BEARING:
        return range_bearing_inverse(x, y, th, z0, z1)
    return cartesian_inverse(x, y, th, z0, z1)


@kernel
def inverse_jacobian(
    model: int, th: float, z0: float, z1: float
) -> tuple[float, float, float, float, float, float]:
    """``(l02, l12, w00, w01, w10, w11)`` of the inverse of measurement model ``model``."""
    if model == RANGE_BEARING:
        return range_bearing_inverse_jacobian(th, z0, z1)
    return cartesian_inverse_jacobian(th, z0, z1)


# What :func:`measurement_many` computes.
H, H_JACOBIAN, H_INVERSE, H_INVERSE_JACOBIAN, H_SINGULAR = 0, 1, 2, 3, 4


@kernel
def measurement_many(
    what: int, model: int, x: float, y: float, th: float, points: np.ndarray, out: np.ndarray
) -> None:
    """One model function over many points: row i of ``out`` gets ``what`` of
    ``points[i]`` (landmarks for :data:`H`, :data:`H_JACOBIAN`, :data:`H_SINGULAR`;
    measurements for :data:`H_INVERSE`, :data:`H_INVERSE_JACOBIAN`).

    points: (k, 2); out: (k, 2) for H and H_INVERSE, (k, 10) for H_JACOBIAN (the two
    rows of [H_x | H_m]), (k, 6) for H_INVERSE_JACOBIAN, (k, 1) (1.0 where singular)
    for H_SINGULAR. For the array functions of :mod:`slam_env.ekf.models`."""
    for i in range(points.shape[0]):
        p0 = points[i, 0]
        p1 = points[i, 1]
        if what == H:
            out[i, 0], out[i, 1] = observe(model, x, y, th, p0, p1)
        elif what == H_INVERSE:
            out[i, 0], out[i, 1] = inverse(model, x, y, th, p0, p1)
        elif what == H_JACOBIAN:
            row = jacobian(model, x, y, th, p0, p1)
            for j in range(10):
                out[i, j] = row[j]
        elif what == H_INVERSE_JACOBIAN:
            lw = inverse_jacobian(model, th, p0, p1)
            for j in range(6):
                out[i, j] = lw[j]
        else:
            out[i, 0] = 1.0 if singular(model, x, y, p0, p1) else 0.0

"""Procedural motions (walk, jog, box, gestures, throwcatch) as canonical body points over time.

No external data is needed: each motion is a small kinematic program in the HumanEva world (mm,
Z up, floor at Z = 0) producing the 20 canonical points of :mod:`voxelmocap.synth.skeletons`.

How the motions are built, so that they look like the real thing rather than a swinging stick:

* **Walk / jog** follow an elliptical path around the capture area (as HumanEva's subjects do).
  Footprints are laid along the path (stride length = speed / stride frequency, step width
  ~ 0.1 × height), the stance foot stays planted on its footprint and rolls over the toe before
  toe-off (heel rise to 50°/45°), the swing foot follows a minimum-jerk curve to the next
  footprint with toe clearance. The pelvis moves along the path with the classic vertical bob
  (a sinusoid, lowest at double support, as high as the nearly straight stance leg allows at
  mid-stance), lateral sway towards the stance foot and ±5° pelvic rotation; the
  thorax counter-rotates; arms swing opposite to the legs (±12° walk, ±30° jog, elbows 20°/85°).
  Knees come from two-link inverse kinematics, so hip and knee angle curves emerge from the foot
  and pelvis trajectories (double-hump knee curve for walking; flight phase for jogging, duty
  factor 0.62 / 0.38 at 0.88 / 1.35 Hz stride frequency and 1.0 / 2.3 m/s).
* **Box, gestures, throwcatch** stand in a fixed stance; wrist targets move through key poses
  (guard, jab, cross, hook, uppercut; wave, point, beckon; wind-up, throw, follow-through,
  two-handed catch) interpolated with monotone cubics, the elbows placed by two-link IK with a
  natural elbow direction, the thorax twisting with the arm actions and the body bouncing or
  shifting weight.

All lengths scale with the subject's height; a seed varies speed, timing and path phase a little.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import PchipInterpolator

from ..errors import InputError
from .skeletons import CANONICAL_NAMES

__all__ = ["MOTIONS", "Proportions", "procedural_points"]

MOTIONS = ("walk", "jog", "box", "gestures", "throwcatch")

_C = {name: i for i, name in enumerate(CANONICAL_NAMES)}


@dataclass(frozen=True)
class Proportions:
    """Segment lengths (mm) of a procedural subject, from the stature (Drillis–Contini ratios)."""

    height: float = 1750.0

    def __getattr__(self, name):  # lengths as fractions of the height
        ratios = {
            "torso": 0.290, "hip_offset": 0.052, "shoulder_offset": 0.105, "shoulder_drop": 0.018,
            "neck": 0.055, "head_len": 0.180, "upper_arm": 0.170, "forearm": 0.145,
            "hand": 0.055, "thigh": 0.245, "shin": 0.243, "ankle_h": 0.040, "foot": 0.078,
        }
        if name in ratios:
            return ratios[name] * self.height
        raise AttributeError(name)


# ---------------------------------------------------------------------- small geometry helpers
def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _frame(yaw, pitch=0.0, roll=0.0):
    """Rotation matrices (T, 3, 3) whose columns are the forward, left and up axes.

    ``yaw`` turns forward towards left (about world Z), ``pitch`` leans forward, ``roll`` leans
    to the left; angles in radians, applied yaw · pitch · roll.
    """
    yaw, pitch, roll = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (yaw, pitch, roll)))
    cy, sy, cp, sp, cr, sr = (np.cos(yaw), np.sin(yaw), np.cos(pitch), np.sin(pitch),
                              np.cos(roll), np.sin(roll))
    T = yaw.shape
    z, o = np.zeros(T), np.ones(T)
    Rz = np.stack([np.stack([cy, -sy, z], -1), np.stack([sy, cy, z], -1), np.stack([z, z, o], -1)], -2)
    Ry = np.stack([np.stack([cp, z, sp], -1), np.stack([z, o, z], -1), np.stack([-sp, z, cp], -1)], -2)
    # Lean left = rotation about forward by −roll (up goes towards +left).
    Rx = np.stack([np.stack([o, z, z], -1), np.stack([z, cr, sr], -1), np.stack([z, -sr, cr], -1)], -2)
    return Rz @ Ry @ Rx


def _two_link(root, target, l1, l2, pole):
    """Middle joint (knee/elbow) and reachable end of a two-link chain; arrays (T, 3)."""
    d = target - root
    dist = np.linalg.norm(d, axis=-1, keepdims=True)
    dhat = d / np.maximum(dist, 1e-9)
    dist = np.clip(dist, abs(l1 - l2) + 1.0, (l1 + l2) * 0.9995)
    end = root + dhat * dist
    a = (l1 * l1 - l2 * l2 + dist * dist) / (2 * dist)
    h = np.sqrt(np.maximum(l1 * l1 - a * a, 0.0))
    p = pole - np.sum(pole * dhat, axis=-1, keepdims=True) * dhat
    p = _unit(p + 1e-9)
    return root + dhat * a + p * h, end


def _smooth(u):
    """Minimum-jerk ramp 0 → 1 on u ∈ [0, 1] (clipped outside)."""
    u = np.clip(u, 0.0, 1.0)
    return u * u * u * (10 - 15 * u + 6 * u * u)


def _keys(t, period, times, values):
    """Periodic monotone-cubic interpolation of key values ``(K, ...)`` at ``times`` (s)."""
    times = np.asarray(times, dtype=float)
    values = np.asarray(values, dtype=float)
    tt = np.concatenate([times - period, times, times + period])
    vv = np.concatenate([values, values, values])
    return PchipInterpolator(tt, vv, axis=0)(np.mod(t, period))


# ---------------------------------------------------------------------- assembly
def _assemble(P: Proportions, pelvis, Rp, Rt, Rh, ankles, foot_dirs, wrists, elbow_poles,
              knee_poles):
    """Canonical points (T, 20, 3) from pelvis/thorax/head frames and ankle/wrist targets."""
    T = pelvis.shape[0]
    out = np.empty((T, len(CANONICAL_NAMES), 3))
    l_p = Rp[..., 1]
    f_t, l_t, u_t = Rt[..., 0], Rt[..., 1], Rt[..., 2]
    out[:, _C["pelvis"]] = pelvis
    thorax = pelvis + u_t * P.torso
    out[:, _C["thorax"]] = thorax
    out[:, _C["head"]] = thorax + Rh[..., 2] * P.neck + Rh[..., 0] * 0.01 * P.height
    out[:, _C["head_top"]] = thorax + Rh[..., 2] * P.head_len - Rh[..., 0] * 0.012 * P.height
    for k, side in enumerate("lr"):
        sgn = 1.0 if side == "l" else -1.0
        hip = pelvis + sgn * l_p * P.hip_offset
        knee, ankle = _two_link(hip, ankles[:, k], P.thigh, P.shin, knee_poles[:, k])
        out[:, _C[f"{side}_hip"]] = hip
        out[:, _C[f"{side}_knee"]] = knee
        out[:, _C[f"{side}_ankle"]] = ankle
        out[:, _C[f"{side}_toe"]] = ankle + foot_dirs[:, k] * P.foot
        shoulder = thorax + sgn * l_t * P.shoulder_offset - u_t * P.shoulder_drop
        elbow, wrist = _two_link(shoulder, wrists[:, k], P.upper_arm, P.forearm, elbow_poles[:, k])
        out[:, _C[f"{side}_shoulder"]] = shoulder
        out[:, _C[f"{side}_elbow"]] = elbow
        out[:, _C[f"{side}_wrist"]] = wrist
        out[:, _C[f"{side}_hand"]] = wrist + _unit(wrist - elbow + 0.15 * f_t * P.forearm) * P.hand
    return out


def _arm_fk(P, shoulder, Rt, flex, abd, elbow, sgn):
    """Wrist positions (T, 3) from shoulder flexion/abduction and elbow flexion (radians)."""
    f_t, l_t, u_t = Rt[..., 0], Rt[..., 1], Rt[..., 2]
    upper = (np.sin(flex)[:, None] * f_t - np.cos(flex)[:, None] * np.cos(abd)[:, None] * u_t
             + sgn * np.sin(abd)[:, None] * np.cos(flex)[:, None] * l_t)
    upper = _unit(upper)
    # The forearm bends forward/up in the plane of the upper arm and the thorax forward axis.
    side = _unit(np.cross(upper, f_t))
    fwd = _unit(np.cross(side, upper))
    fore = np.cos(elbow)[:, None] * upper + np.sin(elbow)[:, None] * fwd
    elbow_pos = shoulder + upper * P.upper_arm
    return elbow_pos + fore * P.forearm


# ---------------------------------------------------------------------- locomotion
_GAIT = {
    #        speed m/s, stride Hz, duty, toe lift, heel rise°, bob, sway, arm swing°, elbow°, lean°
    "walk": (1.00, 0.88, 0.62, 0.100, 50.0, 0.020, 0.022, 12.0, 20.0, 3.0),
    "jog": (2.30, 1.35, 0.38, 0.300, 45.0, 0.035, 0.012, 30.0, 85.0, 8.0),
}


def _ellipse_path(s, a, b, theta0):
    """Positions (T, 2) and unit tangents (T, 2) at arc lengths ``s`` on an ellipse (mm)."""
    th = np.linspace(0, 2 * np.pi, 4097)
    pts = np.stack([a * np.cos(th), b * np.sin(th)], -1)
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    arc = np.concatenate([[0.0], np.cumsum(seg)])
    per = arc[-1]
    arc0 = np.interp(theta0 % (2 * np.pi), th, arc)
    theta = np.interp(np.mod(s + arc0, per), arc, th)
    pos = np.stack([a * np.cos(theta), b * np.sin(theta)], -1)
    tan = _unit(np.stack([-a * np.sin(theta), b * np.cos(theta)], -1))
    return pos, tan


def _walk_pelvis_height(t, feet, trunk, P: Proportions, freq, duty):
    """Pelvis height (T,) of walking: as high as the loaded legs allow, smoothed.

    The loaded legs (stance, or landing within 3 % of the cycle) must reach their ankles with
    the knee nearly straight (0.996 of the leg length); that bound peaks at mid-stance and dips
    at double support. The pelvis follows the classic two-per-stride sinusoid between the bound's
    peak (95th percentile) and dip (2nd percentile): a continuous bob of ~4–5 cm, lowest in
    double support, without the sudden drop at heel strike that following the bound would give.
    The bound is evaluated on a 240 Hz grid around the requested times.
    """
    rate = 240.0
    tg = np.arange(t.min() - 0.5, t.max() + 0.5 + 1 / rate, 1 / rate)
    ankles, _ = feet(tg)
    pos, _, left, lateral, pel_yaw = trunk(tg)
    leg = P.thigh + P.shin
    z = np.full(len(tg), P.ankle_h + 0.992 * leg)
    for k, sgn in enumerate((1.0, -1.0)):
        hip_xy = (pos + left * lateral[:, None]
                  + sgn * P.hip_offset * np.stack([-np.sin(pel_yaw), np.cos(pel_yaw)], -1))
        horiz = np.linalg.norm(ankles[:, k, :2] - hip_xy, axis=1)
        reach = ankles[:, k, 2] + np.sqrt(np.maximum((0.996 * leg) ** 2 - horiz ** 2, 0.0))
        u = np.mod(tg * freq + 0.5 * k, 1.0)
        loaded = (u < duty) | (u > 0.97)
        z = np.where(loaded, np.minimum(z, reach), z)
    # A sinusoid through the bound's peak (mid-stance) and its dips (double support, centred
    # between heel strike and the other foot's toe-off); see the docstring.
    phase0 = 0.5 * (duty - 0.5)
    z_top, z_low = np.percentile(z, 95), np.percentile(z, 2)
    return z_top - (z_top - z_low) * 0.5 * (1 + np.cos(4 * np.pi * (t * freq - phase0)))


def _locomotion(kind, t, P: Proportions, rng):
    speed, freq, duty, lift, heel, bob, sway, arm_amp, elbow0, lean = _GAIT[kind]
    H = P.height
    scale = H / 1750.0
    speed *= 1000.0 * scale * rng.uniform(0.95, 1.05)
    freq *= rng.uniform(0.97, 1.03) / np.sqrt(scale)
    a, b = 1250.0, 800.0  # ellipse semi-axes (mm): inside the 3 m × 2 m capture box
    theta0 = rng.uniform(0, 2 * np.pi)
    step_w = 0.055 * H
    T = len(t)

    def path(s):
        pos, tan = _ellipse_path(s, a, b, theta0)
        left = np.stack([-tan[:, 1], tan[:, 0]], -1)
        return pos, tan, left

    toe_drop = np.arctan2(P.ankle_h - 0.012 * H, P.foot)  # foot's rest pitch (toe below ankle)
    foot_len = P.foot

    def feet(tq):
        """Ankles (T, 2, 3) and unit ankle→toe directions (T, 2, 3) at times ``tq``."""
        n = len(tq)
        ankles = np.empty((n, 2, 3))
        foot_dirs = np.empty((n, 2, 3))
        for k, off in enumerate((0.0, 0.5)):
            ph = tq * freq + off
            cyc = np.floor(ph)
            u = ph - cyc
            # footprint of cycle c: where the body is at mid-stance of that cycle
            s_fp = speed * ((cyc + 0.5 * duty - off) / freq)
            s_next = speed * ((cyc + 1 + 0.5 * duty - off) / freq)
            sgn = 1.0 if k == 0 else -1.0
            pos0, tan0, left0 = path(s_fp)
            pos1, tan1, left1 = path(s_next)
            toe0 = np.concatenate([pos0 + sgn * left0 * step_w / 2 + tan0 * 0.6 * foot_len,
                                   np.full((n, 1), 0.012 * H)], 1)
            toe1 = np.concatenate([pos1 + sgn * left1 * step_w / 2 + tan1 * 0.6 * foot_len,
                                   np.full((n, 1), 0.012 * H)], 1)
            stance = u < duty
            us = u / duty
            usw = (u - duty) / (1 - duty)
            # Heel rise over the last 45 % of stance, accelerating (the heel comes off slowly,
            # then the foot rolls quickly onto the toes); flat again (toes up) during swing.
            beta = np.where(stance, np.radians(heel) * np.clip((us - 0.55) / 0.45, 0, 1) ** 2,
                            np.radians(heel) * (1 - _smooth(usw / 0.6))
                            - np.radians(10) * np.sin(np.pi * np.clip(usw, 0, 1)) ** 2)
            m = _smooth(usw)[:, None]
            toe = np.where(stance[:, None], toe0, toe0 + (toe1 - toe0) * m)
            tan = np.where(stance[:, None], tan0, _unit(tan0 + (tan1 - tan0) * m))
            fwd3 = np.concatenate([tan, np.zeros((n, 1))], 1)
            ang = toe_drop + beta
            fd = np.cos(ang)[:, None] * fwd3 - np.sin(ang)[:, None] * np.array([0, 0, 1.0])
            # Swing: the ankle rises early (the knee flexes to lift the foot behind the body,
            # heel up to ~0.2 m in walking, a heel kick in jogging), then lowers to the next
            # footprint.
            bump = np.sin(np.pi * np.sqrt(np.clip(usw, 0, 1))) ** 2
            ankle = toe - fd * foot_len
            ankle[:, 2] += np.where(stance, 0.0, lift * 1000 * scale * bump)
            foot_dirs[:, k] = fd
            ankles[:, k] = ankle
        return ankles, foot_dirs

    def trunk(tq):
        """Path point, tangent, left, lateral sway and pelvis yaw at times ``tq``."""
        pos, tan, left = path(speed * tq)
        ph2 = 2 * np.pi * tq * freq
        lateral = sway * 1000 * scale * np.sin(ph2 - np.pi * duty)
        pel_yaw = np.arctan2(tan[:, 1], tan[:, 0]) + np.radians(5) * np.cos(ph2)
        return pos, tan, left, lateral, pel_yaw

    ankles, foot_dirs = feet(t)
    pos, tan, left, lateral, pel_yaw = trunk(t)
    phase_l = t * freq
    ph2 = 2 * np.pi * phase_l
    heading = np.arctan2(tan[:, 1], tan[:, 0])
    leg = P.thigh + P.shin
    if kind == "walk":
        z = _walk_pelvis_height(t, feet, trunk, P, freq, duty)
    else:  # jog: highest in flight, knees ≈ 40° at mid-stance
        z = (P.ankle_h + 0.925 * leg
             + bob * 1000 * scale * 0.5 * (1 - np.cos(2 * ph2 - 2 * np.pi * duty)))
    pelvis = np.concatenate([pos + left * lateral[:, None], z[:, None]], 1)
    Rp = _frame(pel_yaw, 0.0, np.radians(3) * np.sin(ph2))
    Rt = _frame(heading - np.radians(4) * np.cos(ph2), np.radians(lean), 0.0)
    Rh = _frame(heading, np.radians(lean * 0.3 + 2), 0.0)
    wrists = np.empty((T, 2, 3))
    thorax = pelvis + Rt[..., 2] * P.torso
    for k, sgn in enumerate((1.0, -1.0)):
        swing = np.cos(ph2 + np.pi * k)  # +1: this arm back (its own leg forward, phase 0)
        flex = np.radians(4 - arm_amp * swing)
        elbow = np.radians(elbow0 + 10 * (1 - swing) / 2)
        shoulder = thorax + sgn * Rt[..., 1] * P.shoulder_offset - Rt[..., 2] * P.shoulder_drop
        wrists[:, k] = _arm_fk(P, shoulder, Rt, flex, np.radians(8) * np.ones(T), elbow, sgn)
    elbow_poles = np.stack([-Rt[..., 0] + 0.3 * Rt[..., 1], -Rt[..., 0] - 0.3 * Rt[..., 1]], 1)
    knee_poles = np.stack([Rp[..., 0], Rp[..., 0]], 1)
    return _assemble(P, pelvis, Rp, Rt, Rh, ankles, foot_dirs, wrists, elbow_poles, knee_poles)


# ---------------------------------------------------------------------- standing actions
def _standing_base(t, P, rng, *, stance_w, stagger, knee_bend, bounce_hz, bounce, yaw0):
    """Pelvis, frames and planted feet for a standing subject facing ``yaw0``."""
    T = len(t)
    scale = P.height / 1750.0
    base_yaw = np.full(T, yaw0)
    fwd = np.array([np.cos(yaw0), np.sin(yaw0), 0.0])
    left = np.array([-np.sin(yaw0), np.cos(yaw0), 0.0])
    centre = np.array([rng.uniform(-150, 150), rng.uniform(-100, 100), 0.0]) * scale
    ankles = np.empty((T, 2, 3))
    foot_dirs = np.empty((T, 2, 3))
    toe_drop = np.arctan2(P.ankle_h - 0.012 * P.height, P.foot)
    for k, sgn in enumerate((1.0, -1.0)):
        out = np.radians(12) * sgn  # feet turned out a little
        fd_h = np.cos(out) * fwd + np.sin(out) * left
        fd = np.cos(toe_drop) * fd_h - np.sin(toe_drop) * np.array([0, 0, 1.0])
        pos = (centre + sgn * left * stance_w * scale / 2 + sgn * fwd * stagger * scale / 2
               + np.array([0, 0, P.ankle_h]))
        ankles[:, k] = pos
        foot_dirs[:, k] = fd
    leg = P.thigh + P.shin
    z = P.ankle_h + leg * np.cos(np.radians(knee_bend)) + bounce * scale * np.sin(
        2 * np.pi * bounce_hz * t)
    pelvis = np.tile(centre, (T, 1)).astype(float)
    pelvis[:, 2] = z
    return pelvis, base_yaw, fwd, left, ankles, foot_dirs


def _standing(kind, t, P: Proportions, rng):
    T = len(t)
    s = P.height / 1750.0
    yaw0 = rng.uniform(-np.pi, np.pi)
    mm = 1000.0 * s
    if kind == "box":
        period = 2.4 * rng.uniform(0.95, 1.05)
        pelvis, yaw, fwd, left, ankles, foot_dirs = _standing_base(
            t, P, rng, stance_w=380, stagger=300, knee_bend=22, bounce_hz=2.5, bounce=15,
            yaw0=yaw0)
        # wrist targets relative to each shoulder in thorax axes (forward, left, up), metres
        guard_l, guard_r = (0.24, -0.10, 0.02), (0.22, 0.12, 0.04)
        kt = [0.0, 0.14, 0.40, 0.72, 1.02, 1.32, 1.58, 1.88, 2.16]
        wl = [guard_l, (0.52, -0.12, 0.03), guard_l, guard_l, guard_l,
              (0.28, -0.42, 0.02), guard_l, guard_l, guard_l]
        wr = [guard_r, guard_r, guard_r, (0.52, 0.17, 0.05), guard_r, guard_r, guard_r,
              (0.32, 0.12, 0.12), guard_r]
        twist = [0.0, -8.0, 0.0, 25.0, 0.0, -22.0, 0.0, 15.0, 0.0]
        lean_k = [8.0, 10.0, 8.0, 12.0, 8.0, 9.0, 8.0, 4.0, 8.0]
        kt = np.array(kt) * period / 2.4
    elif kind == "gestures":
        period = 7.0 * rng.uniform(0.95, 1.05)
        pelvis, yaw, fwd, left, ankles, foot_dirs = _standing_base(
            t, P, rng, stance_w=260, stagger=40, knee_bend=6, bounce_hz=0.2, bounce=6, yaw0=yaw0)
        rest_l, rest_r = (0.04, 0.06, -0.50), (0.04, -0.06, -0.50)
        up_r = (0.12, -0.10, 0.33)
        kt = [0.0, 0.7, 1.0, 1.25, 1.5, 1.75, 2.0, 2.5, 3.2, 3.8, 4.5, 5.0, 5.35, 5.7, 6.0, 6.5]
        wl = [rest_l, rest_l, rest_l, rest_l, rest_l, rest_l, rest_l, rest_l,
              (0.48, 0.20, 0.10), (0.48, 0.20, 0.10), rest_l,
              (0.28, -0.02, -0.12), (0.18, -0.02, 0.02), (0.28, -0.02, -0.12), rest_l, rest_l]
        wr = [rest_r, up_r, (0.12, -0.24, 0.30), up_r, (0.12, -0.24, 0.30), up_r,
              (0.12, -0.24, 0.30), rest_r, rest_r, rest_r, rest_r,
              (0.28, 0.02, -0.12), (0.18, 0.02, 0.02), (0.28, 0.02, -0.12), rest_r, rest_r]
        twist = [0, -5, -5, -5, -5, -5, -5, 0, 12, 12, 0, 0, 0, 0, 0, 0]
        lean_k = [2, 1, 1, 1, 1, 1, 1, 2, 4, 4, 2, 5, 5, 5, 2, 2]
        kt = np.array(kt) * period / 7.0
    elif kind == "throwcatch":
        period = 3.2 * rng.uniform(0.95, 1.05)
        pelvis, yaw, fwd, left, ankles, foot_dirs = _standing_base(
            t, P, rng, stance_w=330, stagger=260, knee_bend=12, bounce_hz=0.3, bounce=8,
            yaw0=yaw0)
        ready_l, ready_r = (0.30, -0.14, -0.18), (0.30, 0.14, -0.18)
        kt = [0.0, 0.5, 0.95, 1.12, 1.3, 1.6, 2.1, 2.45, 2.7, 3.0]
        wl = [ready_l, (0.35, 0.05, -0.05), (0.42, 0.10, 0.05), (0.30, 0.08, -0.10),
              (0.10, 0.12, -0.40), (0.05, 0.08, -0.48), ready_l, (0.45, -0.12, 0.02),
              ready_l, ready_l]
        wr = [ready_r, (-0.05, -0.12, 0.12), (-0.25, -0.08, 0.28), (0.30, 0.0, 0.30),
              (0.42, 0.20, -0.12), (0.20, 0.10, -0.40), ready_r, (0.45, 0.12, 0.02),
              ready_r, ready_r]
        twist = [0, -15, -35, 5, 30, 15, 0, 0, 0, 0]
        lean_k = [5, 2, -4, 10, 18, 10, 5, 8, 5, 5]
        kt = np.array(kt) * period / 3.2
    else:  # pragma: no cover - guarded by procedural_points
        raise AssertionError(kind)
    tw = np.radians(_keys(t, period, kt, twist))
    ln = np.radians(_keys(t, period, kt, lean_k))
    Rp = _frame(yaw + 0.35 * tw, 0.3 * ln, 0.0)
    Rt = _frame(yaw + tw, ln, np.radians(2) * np.sin(2 * np.pi * t / period))
    Rh = _frame(yaw + 0.6 * tw, 0.5 * ln - np.radians(3), 0.0)
    if kind == "throwcatch":  # weight shift forward during the throw
        shift = _keys(t, period, kt, [0, -40, -80, 30, 90, 60, 0, 20, 0, 0]) * s
        pelvis = pelvis + shift[:, None] * fwd[None, :]
    thorax = pelvis + Rt[..., 2] * P.torso
    wrists = np.empty((T, 2, 3))
    for k, (keys, sgn) in enumerate(((wl, 1.0), (wr, -1.0))):
        loc = _keys(t, period, kt, np.asarray(keys)) * mm
        shoulder = thorax + sgn * Rt[..., 1] * P.shoulder_offset - Rt[..., 2] * P.shoulder_drop
        wrists[:, k] = (shoulder + loc[:, :1] * Rt[..., 0] + loc[:, 1:2] * Rt[..., 1]
                        + loc[:, 2:] * Rt[..., 2])
    # elbows point down, back and out (out more when the hand is high, as in a wave or a hook)
    elbow_poles = np.stack([-Rt[..., 2] - 0.4 * Rt[..., 0] + 0.5 * Rt[..., 1],
                            -Rt[..., 2] - 0.4 * Rt[..., 0] - 0.5 * Rt[..., 1]], 1)
    knee_poles = np.stack([_unit(fwd + 0.25 * left)] * 2, 0)[None].repeat(T, 0)
    knee_poles[:, 1] = _unit(fwd - 0.25 * left)
    return _assemble(P, pelvis, Rp, Rt, Rh, ankles, foot_dirs, wrists, elbow_poles, knee_poles)


def procedural_points(kind: str, times, *, height: float = 1750.0, seed=0) -> np.ndarray:
    """Canonical points of a procedural motion.

    Parameters
    ----------
    kind : {"walk", "jog", "box", "gestures", "throwcatch"}
        The motion.
    times : (T,) array_like of float
        Times in seconds (any real values; the motions are periodic or unbounded).
    height : float
        Subject stature in mm; all lengths scale with it.
    seed : int or numpy.random.Generator
        Varies speed, timing, facing and path phase a little.

    Returns
    -------
    (T, 20, 3) ndarray
        Canonical points (:data:`~voxelmocap.synth.skeletons.CANONICAL_NAMES`), mm, Z up.
    """
    if kind not in MOTIONS:
        raise InputError("--motion", f"unknown motion {kind!r} (choose {', '.join(MOTIONS)} "
                                     "or a .bvh file)")
    rng = np.random.default_rng(seed)
    t = np.asarray(times, dtype=float).reshape(-1)
    P = Proportions(float(height))
    if kind in ("walk", "jog"):
        return _locomotion(kind, t, P, rng)
    return _standing(kind, t, P, rng)

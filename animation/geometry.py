"""Where every drawn part of the wheel is: poses from the coordinates, by the model's own kinematics.

The picture must use exactly the FMU's conventions, so the poses are not re-derived here: CasADi
evaluates model/kinematics.py's WheelKinematics (paper section 2, docs/interface.md):
- centre C = (x, y, R sin beta) (holonomic constraint, eq. 21), beta = pi/2 upright;
- the frame {l, m, n} of eqs. (9)-(11): l from the centre towards the contact point, m = -(cos alpha,
  sin alpha, 0) horizontal, n the axle;
- the wheel's material frame {l, m, n} Rz(gamma): a mark painted on the wheel turns with the spin;
- the contact point A = C + R l (eq. 14).
The Gyrover's internal assembly follows model/effects/gyrover.py: it swings by theta_p in the wheel
plane, l_p = cos(theta_p) l + sin(theta_p) m, m_p = -sin(theta_p) l + cos(theta_p) m; the flywheel's
centre is C + L_pend l_p and its spin axis a = cos(tilt) n + sin(tilt) l_p (tilted about m_p).
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import casadi as ca
import numpy as np

from gyrowheel.model.kinematics import WheelKinematics


@dataclass
class Poses:
    """Poses at N instants, ground coordinates (x, y horizontal, z up), metres.

    body[k] has columns (e_1, e_2, n): e_1, e_2 span the wheel plane and turn with the spin
    (e_1 = l at gamma = 0), n is the axle. fly_frame[k] has columns (m_p, a x m_p, a) of the
    flywheel (a its spin axis, m_p its tilt axis); fly_centre and fly_frame are None without a gyrover.
    """

    centre: np.ndarray  # (N, 3)
    body: np.ndarray  # (N, 3, 3)
    contact: np.ndarray  # (N, 3)
    heading: np.ndarray  # (N, 3): (cos alpha, sin alpha, 0) = -m, the rolling direction for gamma_dot > 0
    fly_centre: np.ndarray | None = None  # (N, 3)
    fly_frame: np.ndarray | None = None  # (N, 3, 3)


@functools.lru_cache(maxsize=1)
def _pose_function() -> ca.Function:
    q, qd = ca.SX.sym("q", 5), ca.SX.sym("qd", 5)
    R, L_pend, theta_p, tilt = ca.SX.sym("R"), ca.SX.sym("L_pend"), ca.SX.sym("theta_p"), ca.SX.sym("tilt")
    kin = WheelKinematics(q, qd, R)
    l, m, n = kin.l, kin.m, kin.n
    l_p = ca.cos(theta_p) * l + ca.sin(theta_p) * m
    m_p = -ca.sin(theta_p) * l + ca.cos(theta_p) * m
    axis = ca.cos(tilt) * n + ca.sin(tilt) * l_p
    fly_frame = ca.horzcat(m_p, ca.cross(axis, m_p), axis)
    return ca.Function("wheel_pose", [q, R, theta_p, tilt, L_pend],
                       [kin.centre, kin.body, kin.contact, -m, kin.centre + L_pend * l_p, fly_frame],
                       ["q", "R", "theta_p", "tilt", "L_pend"],
                       ["centre", "body", "contact", "heading", "fly_centre", "fly_frame"])


def _stack(matrix: ca.DM, count: int) -> np.ndarray:
    """CasADi map output 3 x (3 N) (blocks side by side) -> (N, 3, 3)."""
    return np.array(matrix).reshape(3, count, 3).transpose(1, 0, 2)


def wheel_poses(q: np.ndarray, R: float, theta_p: np.ndarray | None = None, tilt: np.ndarray | None = None,
                L_pend: float = 0.0) -> Poses:
    """Poses of the wheel (and of the Gyrover's flywheel when theta_p and tilt are given).

    q: (N, 5) rows (x, y, alpha, beta, gamma) in m and rad; R: rolling radius, m; theta_p, tilt: (N,)
    in rad; L_pend: distance of the flywheel's centre from the axle, m. Raises ValueError on shapes.
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    if q.ndim != 2 or q.shape[1] != 5:
        raise ValueError(f"q must have shape (N, 5) (x, y, alpha, beta, gamma), got {q.shape}")
    count = q.shape[0]
    gyro = theta_p is not None and tilt is not None
    th = np.zeros(count) if theta_p is None else np.asarray(theta_p, dtype=float).reshape(count)
    ti = np.zeros(count) if tilt is None else np.asarray(tilt, dtype=float).reshape(count)
    f = _pose_function().map(count)
    out = f(q.T, np.full((1, count), R), th[None, :], ti[None, :], np.full((1, count), L_pend))
    centre, body, contact, heading, fly_centre, fly_frame = out
    return Poses(centre=np.array(centre).T, body=_stack(body, count), contact=np.array(contact).T,
                 heading=np.array(heading).T,
                 fly_centre=np.array(fly_centre).T if gyro else None,
                 fly_frame=_stack(fly_frame, count) if gyro else None)


def circle_points(centre: np.ndarray, frame: np.ndarray, radius: float, phi: np.ndarray) -> np.ndarray:
    """Points centre + radius (cos phi e_1 + sin phi e_2) of circles in the planes of frame's first
    two columns: centre (N, 3), frame (N, 3, 3), phi (P,) rad -> (N, P, 3). With a wheel's body frame
    and R these are material points of the rim (phi = 0 is the contact point at gamma = 0)."""
    e1, e2 = frame[:, None, :, 0], frame[:, None, :, 1]
    return centre[:, None, :] + radius * (np.cos(phi)[None, :, None] * e1 + np.sin(phi)[None, :, None] * e2)


def flywheel_radius(I_fly_axial: float, m_fly: float, R: float) -> float:
    """Drawn radius of the flywheel: the uniform disc with its mass and axial inertia,
    r = sqrt(2 I_fly_axial / m_fly), at most 0.9 R (a drawing size only; 0.3 R without mass)."""
    r = math.sqrt(2.0 * I_fly_axial / m_fly) if m_fly > 0 and I_fly_axial > 0 else 0.3 * R
    return min(r, 0.9 * R)

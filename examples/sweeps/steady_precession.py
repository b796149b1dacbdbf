"""Helpers for `gyrowheel sweep` runs of steady precession (examples/sweeps/paper_figs_5_6.py).

    --derive examples/sweeps/steady_precession.py:start
        a point's rho [m] (with beta or beta_deg, and the wheel's M, R, k_diam, k_axial, g) -> the
        start rates of eqs. (52) and (49) corrected, plus a nudge beta_dot = NUDGE so that an
        unstable precession shows within the run instead of waiting for round-off
    --metric-function examples/sweeps/steady_precession.py:steadiness
        did the motion stay steady? lean deviation, fitted circle radius, mean centre speed
"""
import numpy as np

from gyrowheel.studies.analysis import fit_circle
from gyrowheel.model.steady import precession_rates

NUDGE = 1e-6  # rad/s of lean rate added to the equilibrium
STEADY_BETA = 1e-3  # rad: the lean may move this much and the motion still counts as steady
STEADY_RHO = 1e-3  # relative error of the circle's radius allowed


def start(point, values):
    keys = ("M", "R", "k_diam", "k_axial", "g")
    alpha_dot, gamma_dot = precession_rates(values["beta"], point["rho"], **{k: values[k] for k in keys})
    return {"alpha_dot": alpha_dot, "gamma_dot": gamma_dot, "beta_dot": NUDGE}


def steadiness(traj, point):
    beta_dev = float(np.max(np.abs(traj["beta"] - traj["beta"][0])))
    _, _, rho_sim = fit_circle(traj["x"], traj["y"])
    v_sim = float(np.mean(np.hypot(traj["vx"], traj["vy"])))
    steady = bool(beta_dev < STEADY_BETA and abs(rho_sim - point["rho"]) < STEADY_RHO * point["rho"])
    return {"v_sim": v_sim, "rho_sim": rho_sim, "beta_dev": beta_dev, "steady": steady}

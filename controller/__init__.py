"""The Gyrover's balance and steering controller, designed from the wheel's own equations.

design.py: linear model (model/linearise.py), controllability, LQR + Kalman observer, gains file;
compensator.py: the controller as a small CasADi system (model/system.py) -> FMU;
mission.py: the heading and speed references of a mission.
"""

"""Independent reference models of the Nandy & Xu rolling wheel (for tests only).

- :mod:`tests.reference.newton_euler` -- Newton-Euler derivation with the contact force
  as unknown (the main reference: rhs, contact force, energy, steady precession,
  critical spin, simulate).
- :mod:`tests.reference.lagrange_sympy` -- a small Lagrange-multiplier derivation from
  the kinetic energy of eq. (25) (generalised inertia, z = R sin(beta) kept), used to
  cross-check the Newton-Euler one.

Both are written in sympy and share nothing with the project's CasADi model.
"""

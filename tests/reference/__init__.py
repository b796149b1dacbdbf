"""Independent reference models of the Nandy & Xu rolling wheel (for tests only).

- :mod:`reference.newton_euler` -- Newton-Euler derivation with the contact force
  as unknown (the main reference: rhs, contact force, energy, steady precession,
  critical spin, simulate).
- :mod:`reference.lagrange_sympy` -- a small Lagrange-multiplier derivation from
  the kinetic energy of eq. (25) (generalised inertia, z = R sin(beta) kept), used to
  cross-check the Newton-Euler one.

Both are written in sympy and share nothing with the project's CasADi model.
Tests import them as ``from reference import newton_euler`` (tests/ is on sys.path under
pytest); ``tests.reference.newton_euler`` works too from the repository root.
"""

"""Independent reference models of the Nandy & Xu rolling wheel (for tests only).

- :mod:`reference.newton_euler` -- Newton-Euler derivation with the contact force
  as unknown (the main reference: rhs, contact force, energy, steady precession,
  critical spin, simulate).
- :mod:`reference.lagrange_sympy` -- a small Lagrange-multiplier derivation from
  the kinetic energy of eq. (25) (generalised inertia, z = R sin(beta) kept), used to
  cross-check the Newton-Euler one.

- :mod:`reference.soft_contact` -- the wheel as a free rigid body (quaternion Newton-Euler,
  scipy) on a plane with a penalty normal contact and regularised Coulomb friction: rolling,
  sliding, flight and impacts without a hybrid model; :mod:`reference.soft_contact_scenarios`
  runs the contact scenarios (sliding launch, incline, flight, drops) on it.

The sympy ones share nothing with the project's CasADi model; the soft-contact one shares only
its conventions (docs/model.md).
Tests import them as ``from reference import newton_euler`` (tests/ is on sys.path under
pytest); ``tests.reference.newton_euler`` works too from the repository root.
"""

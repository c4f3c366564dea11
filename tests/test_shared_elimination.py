"""Common subexpressions are eliminated once over all generated functions
(codegen/functions.py prepare_all): an intermediate keeps one name and one expression in every
function, so a quantity that several functions return comes out with the same bits from each."""

from __future__ import annotations

import numpy as np

import gpmegen


def test_gpme_terms_give_the_bits_of_the_functions_that_return_the_same_quantities(env):
    model = gpmegen.load("manipulator", nrfe=3, backend="numpy")
    module, p = model.module, np.array(model.module.DEFAULTS)
    rng = np.random.default_rng(5)
    for _ in range(5):
        q = 0.4 * rng.standard_normal(model.n_dof)
        q[model.index("psi2")] += np.pi / 4
        qd, t = rng.standard_normal(model.n_dof), float(rng.uniform(0, 3))
        M, f, *terms = module.gpme_terms(t, q, qd, p)
        assert np.array_equal(M, module.mass_matrix(q, p))
        assert np.array_equal(f, module.forces(t, q, qd, p))
        for a, b in zip(terms, module.constraint_terms(t, q, qd, p), strict=True):
            assert np.array_equal(a, b)

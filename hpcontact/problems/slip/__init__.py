"""Partial slip: two bodies pressed together, then loaded tangentially with Coulomb friction.

``partial_slip`` (``solve_slip`` and ``validate``: the entry of a slip scene), ``problem``
(``SlipProblem``: the pair's operators on the contact grid), ``load_path`` (load steps with
the friction sub-problem), ``bodies`` (isotropic bodies, radii, Hertz's ellipse) and
``crystal_pair`` (pairs with crystal bodies, and ``pair_from_params`` for any pair).
docs/design.md §2.3.
"""

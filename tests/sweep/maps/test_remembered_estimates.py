"""An estimate asked twice in one decision is computed once (``estimates.remembered_estimates``):
after the last check round the judgement and the fill estimate the same quantities with the same
factor; what it returns is bitwise the estimate computed afresh, and changed values at a node
are estimated anew."""

from __future__ import annotations

import numpy as np
from test_spread import bump_map

from hpcontact.sweep.maps import refinement
from hpcontact.sweep.maps.estimates import Checks, remembered_estimates
from hpcontact.sweep.maps.rounds import next_step
from hpcontact.sweep.maps.state import estimate, initial_state, state_tasks


def test_the_last_decisions_fill_estimate_is_the_judgements_and_equals_one_computed_afresh(monkeypatch):
    spec, layout, task_of, every, stored = bump_map()
    state, checks = initial_state(layout, spec.adaptive), Checks()
    while True:  # to the decision after the last check round
        solved = np.isin(task_of, state_tasks(layout, state, task_of, checks))
        seen = {n: np.where(solved, v, np.nan) for n, v in every.items()}
        step = next_step(layout, spec.adaptive, state, checks, seen, ["K_xx"], stored, task_of)
        if not isinstance(step, tuple):
            break
        state, checks = step
    assert checks.rounds >= 1 and step.rounds == checks.rounds + 1 and not step.raised  # judged, not raised
    (cat, leaves), parts = state[0], []
    original = refinement.leaf_estimate

    def counted(job):
        parts.append(job)
        return original(job)

    monkeypatch.setattr(refinement, "leaf_estimate", counted)
    fresh = estimate(layout, cat, leaves, stored, seen, step.factor(0), step.cautious(0))
    computed = len(parts)
    with remembered_estimates():
        assert next_step(layout, spec.adaptive, state, checks, seen, ["K_xx"], stored, task_of) == step
        judged = len(parts)
        again = estimate(layout, cat, leaves, stored, seen, step.factor(0), step.cautious(0))  # the fill's
        assert len(parts) == judged  # no part computed again
        for x, y in zip(
            [fresh.values, fresh.solve, fresh.scale, fresh.owner, *fresh.axes],
            [again.values, again.solve, again.scale, again.owner, *again.axes],
        ):
            assert np.array_equal(x, y, equal_nan=True)
        node = tuple(int(i[0]) for i in np.nonzero(refinement.node_mask(layout, leaves)))
        moved = {n: v.copy() for n, v in seen.items()}
        moved["K_xx"][node] *= 1.5
        other = estimate(layout, cat, leaves, stored, moved, step.factor(0), step.cautious(0))
        assert len(parts) == judged + computed and other is not again
        assert not np.array_equal(other.values, again.values, equal_nan=True)
    assert computed == len(leaves)

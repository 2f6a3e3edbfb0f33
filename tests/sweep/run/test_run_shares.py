"""What the ranks share before they run (``hpcontact.sweep.run.shares``): rank 0's value or
error on every rank, and the first bad share raised alike on every rank (the same on 2 ranks
under MPI: ``tests/mpi/test_parallel_sweep.py``)."""

from __future__ import annotations

import contextlib
import pickle
from typing import Any

import numpy as np
import pytest

from hpcontact.errors import InputError
from hpcontact.sweep.run.schedule import SerialTeam
from hpcontact.sweep.run.shares import Share, SharedError, from_rank_zero, joined


class RankOne(SerialTeam):
    """Rank 1 of two: its broadcast receives what rank 0 sent (``sent``)."""

    rank = 1
    size = 2

    def __init__(self, sent: Any) -> None:
        self.sent = sent

    def bcast(self, obj: Any) -> Any:
        return pickle.loads(pickle.dumps(self.sent))


def rank_zero_sends(make) -> Any:
    """What rank 0 broadcasts when ``make`` runs there (its exception kept from rank 0)."""
    sent = []

    class RankZero(SerialTeam):
        def bcast(self, obj: Any) -> Any:
            sent.append(obj)
            return obj

    with contextlib.suppress(Exception):  # rank 0 raises; what it sent is the point here
        from_rank_zero(RankZero(), make)
    return sent[0]


def test_rank_zero_value_on_every_rank():
    assert from_rank_zero(SerialTeam(), lambda: {"a": 1}) == {"a": 1}
    assert from_rank_zero(RankOne(rank_zero_sends(lambda: 42)), lambda: pytest.fail("rank 1 makes nothing")) == 42


def test_bad_input_on_rank_zero_is_the_same_input_error_on_every_rank():
    error = InputError("axes.nu", "values in (-1, 0.5]", 0.7)

    def make() -> None:
        raise error

    with pytest.raises(InputError) as raised:
        from_rank_zero(SerialTeam(), make)
    assert raised.value is error  # rank 0 raises its own exception (a Refused stays Refused)
    with pytest.raises(InputError) as elsewhere:
        from_rank_zero(RankOne(rank_zero_sends(make)), make)
    assert (elsewhere.value.field, elsewhere.value.allowed, elsewhere.value.value) == (
        "axes.nu",
        "values in (-1, 0.5]",
        0.7,
    )
    assert str(elsewhere.value) == str(error)


def test_another_error_on_rank_zero_is_named_on_every_rank():
    def make() -> None:
        raise ZeroDivisionError("division by zero")

    with pytest.raises(RuntimeError, match="^ZeroDivisionError on rank 0: division by zero$"):
        from_rank_zero(RankOne(rank_zero_sends(make)), make)


def test_the_first_bad_share_in_rank_order_is_raised():
    shares = [
        Share(None, False, None),
        Share(None, False, SharedError.of(InputError("axes.a", "positive", -1.0), 1)),
        Share(None, False, SharedError.of(KeyError("x"), 2)),
    ]
    with pytest.raises(InputError, match="axes.a"):
        joined(None, shares)
    with pytest.raises(RuntimeError, match="^KeyError on rank 2: 'x'$"):
        joined(None, shares[2:])


def test_shares_packed_and_unpacked_join_into_the_tasks_of_one_whole_enumeration():
    """Three ranks' shares of a grid whose scenes repeat across the ranks' ranges (a circle's
    along b/a, the angle ignored in tensor mode), each packed and unpacked as the ranks exchange
    them (``packed``, ``unpacked``) and joined: the tasks (``Task`` rows, key, parameters, cost,
    group) and each point's task of one enumeration of the whole grid, which joins nothing
    (``tasks.join_parts`` of one part; that one against the points one by one:
    ``tests/sweep/work/test_tasks.py``); one group object per distinct group text; a share's
    error survives the trip."""
    from hpcontact.sweep.run.records import NO_FLAGS
    from hpcontact.sweep.run.shares import packed, share, unpacked
    from hpcontact.sweep.space.parse import parse_spec
    from hpcontact.sweep.work.tasks import Task, enumerate_part, join_parts

    text = """
        [axes]
        shape = ["circle", "ellipse"]
        aspect = [1, 0.1, 0.01]
        nu = [0.1, 0.3, 0.5]
        angle = { linspace = [0, 180, 5] }
        """
    spec = parse_spec(text, validate=lambda params: None)
    whole, whole_of = join_parts(spec, [enumerate_part(spec)])
    shares = [unpacked(packed(share(spec, r, 3, None, NO_FLAGS))) for r in range(3)]
    tasks, where, over = joined(spec, shares)
    assert len(whole) < where.size  # scenes repeat
    assert [tuple(t) for t in tasks] == [tuple(t) for t in whole]
    assert np.array_equal(where, whole_of) and not over
    assert all(type(t) is Task for t in tasks)
    assert len({id(t.group) for t in tasks}) == len({t.group for t in tasks})
    bad = Share(None, False, SharedError.of(InputError("axes.nu", "values in (-1, 0.5]", 0.7), 2))
    with pytest.raises(InputError, match="axes.nu"):
        joined(spec, [shares[0], unpacked(packed(bad))])

"""LM-cut on P^C (planning.heuristics.lmcut_pc): mutexes, the pantry round trip, and labels equal to plain LM-cut's."""

import numpy as np

from oracles.labelling import Labeller
from planning.domain.batched import BatchedModel
from planning.heuristics.hmax import goal_literals
from planning.heuristics.lmcut import LMCut
from planning.heuristics.lmcut_pc import ConjunctionLMCut, MutexPairs, agent_pairs


def atom(model, *key):
    return model.atoms.index(tuple(key))


def test_mutexes_of_the_restaurant(three_room):
    m = MutexPairs(three_room, [three_room.init] + [three_room.reset_state(s) for s in range(8)])
    at = lambda *k: atom(three_room, *k)
    assert m.matrix[at("robot-at", "countertop"), at("robot-at", "pantry")]  # one place at a time
    assert m.matrix[at("hand-free"), at("holding", "jar_0")]  # a full hand is not free
    assert m.matrix[at("holding", "jar_0"), at("at", "jar_0", "pantry")]  # held: at no location
    assert not m.matrix[at("robot-at", "pantry"), at("holding", "jar_0")]
    assert not m.matrix[at("dirty", "cup_0"), at("dirty", "cup_1")]
    for s in three_room.random_walk_states(40, seed=2, walk=20):
        assert m.respects(s)
    both = three_room.init | 1 << at("robot-at", "pantry")  # two places at once
    assert not m.respects(both)


def test_pantry_round_trip_is_counted_twice(three_room):
    """pick-place(jar_0, countertop) from the start: 875 there, pick, 875 back, place = 1,950 exactly;
    the plain relaxation walks to the pantry once."""
    bm = BatchedModel(three_room)
    mutex = MutexPairs(three_room, [three_room.init])
    pc = ConjunctionLMCut(three_room, bm, mutex, keep=agent_pairs(three_room))
    goal = goal_literals(three_room, three_room.tasks.get("pick-place(jar_0, countertop)"))
    start = bm.pack([three_room.init])
    assert pc(start, goal)[0] == 1950
    assert LMCut(three_room, bm)(start, goal)[0] < 1950


def test_labels_equal_plain_lmcut(two_room, three_room):
    for model, seed in ((two_room, 4), (three_room, 6)):
        plain, pc = Labeller(model, "lmcut"), Labeller(model, "lmcut-pc")
        assert pc.heuristic == "lmcut-pc" and pc.h.inner.plain is not None  # LM-cut where mutexes break
        closed = np.zeros(2, dtype=int)
        for s in model.random_walk_states(3, seed=seed, walk=12):
            a, b = plain.label(s), pc.label(s)
            assert np.array_equal(a.costs, b.costs)
            closed += a.closed, b.closed
        assert closed[1] < closed[0]  # the point of P^C: fewer states closed

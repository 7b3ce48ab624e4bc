"""The compiled simulator: single and batched paths agree, errors leave states untouched."""

import numpy as np
import pytest

from planning.domain.batched import BatchedModel
from planning.domain.factored import factored_actions
from planning.errors import DomainError


def test_initial_successors(two_room):
    m = two_room
    names = sorted(m.actions[a] for a in m.applicable(m.init))
    assert names == sorted(
        [
            "move(countertop, coffeemachine)",
            "move(countertop, dishwasher)",
            "move(countertop, shelf)",
            "move(countertop, servingtable)",
            "move(countertop, fountain)",
            "pick(cup_0, countertop)",
            "pick(apple_0, countertop)",
            "pick(bowl_0, countertop)",
            "pick(knife_0, countertop)",
        ]
    )
    for a, nxt, c in m.successors(m.init):
        assert nxt == m.apply(m.init, a) and c == m.action_cost[a]


def test_batched_step_equals_single_step(restaurant):
    m = restaurant
    bm = BatchedModel(m)
    states = m.random_walk_states(600, seed=1)
    batch = bm.pack(states)
    assert bm.unpack(batch) == states
    parent, action, nxt, cost = bm.successors(batch)
    batched = sorted(zip(parent.tolist(), action.tolist(), bm.unpack(nxt), cost.tolist()))
    single = sorted((i, a, t, c) for i, s in enumerate(states) for a, t, c in m.successors(s))
    assert batched == single
    mask = bm.applicable(batch)
    assert [list(np.flatnonzero(row)) for row in mask] == [m.applicable(s) for s in states]
    rng = np.random.default_rng(0)
    chosen = np.array([rng.choice(np.flatnonzero(row)) for row in mask])
    stepped, costs = bm.step(batch, chosen)
    assert bm.unpack(stepped) == [m.apply(s, int(a)) for s, a in zip(states, chosen)]
    assert costs.tolist() == [m.action_cost[a] for a in chosen]


def test_bits_view(two_room):
    bm = BatchedModel(two_room)
    states = two_room.random_walk_states(50, seed=2)
    bits = bm.to_bits(bm.pack(states))
    assert bits.shape == (50, two_room.n_atoms)
    for row, s in zip(bits, states):
        assert {two_room.atoms[i] for i in np.flatnonzero(row)} == set(two_room.true_atoms(s))


def test_inapplicable_action_is_an_error_and_state_is_unchanged(two_room):
    m = two_room
    a = m.action("fill(cup_0, water_fountain, fountain)")
    with pytest.raises(DomainError, match=r"fill\(cup_0, water_fountain, fountain\): not applicable"):
        m.apply(m.init, a)
    bm = BatchedModel(m)
    batch = bm.pack([m.init])
    before = batch.copy()
    with pytest.raises(DomainError, match="not applicable"):
        bm.step(batch, np.array([a]))
    assert (batch == before).all()


def test_state_printout(two_room):
    text = two_room.describe(two_room.init)
    assert "robot-at: countertop" in text and "at: cup_0 countertop" in text and "dirty: cup_1" in text


def test_unknown_atom_is_an_error(two_room):
    with pytest.raises(DomainError, match=r"\(at jar_0 pantry\) is not a reachable fluent atom"):
        two_room.state_from_atoms(["(at jar_0 pantry)"])  # no pantry in the two-room layout


def test_states_are_compact_and_hashable(three_room):
    states = three_room.random_walk_states(200, seed=4)
    assert all(isinstance(s, int) and s.bit_length() <= three_room.n_atoms for s in states)
    assert len({s: None for s in states}) == len(set(states))


def test_disjunctive_precondition_gives_one_ground_action(two_room):
    m = two_room
    pour = m.action("pour(cup_0, water_machine, coffeemachine)")
    assert m.op_action.count(pour) == 2  # (or has-water has-coffee)
    s = m.state_from_atoms(
        ["(robot-at coffeemachine)", "(holding cup_0)", "(has-water cup_0)", "(has-coffee cup_0)"]
    )  # both disjuncts (unreachable, but legal)
    assert [a for a, _, _ in m.successors(s)].count(pour) == 1
    bm = BatchedModel(m)
    _, action, _, _ = bm.successors(bm.pack([s]))
    assert action.tolist().count(pour) == 1


def test_factored_labels_are_unique_among_applicable_actions(restaurant):
    f = factored_actions(restaurant)
    for s in restaurant.random_walk_states(500, seed=5):
        labels = f.applicable_labels(restaurant, s)
        assert sorted(labels.values()) == restaurant.applicable(s)

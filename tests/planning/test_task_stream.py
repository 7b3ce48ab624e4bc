"""The persistent world's accounting: budget, abandonment, consumption, resets."""

import pytest

from planning.domain.batched import BatchedModel
from planning.errors import DomainError
from planning.search.optimal import optimal_plan
from planning.world.task_stream import PersistentWorld, TaskStream, draw_tasks
from tests.examples import START_COSTS


def test_abandonment_after_64_actions_charges_the_cost(two_room):
    m = two_room
    world = PersistentWorld(m, reset_seed=0)
    world.state = m.init
    assert not world.begin(m.tasks.get("serve-water(servingtable)"))
    there, back = m.action("move(countertop, shelf)"), m.action("move(shelf, countertop)")
    steps = [world.act(there if i % 2 == 0 else back) for i in range(64)]
    assert not any(s.completed for s in steps[:-1]) and steps[-1].abandoned
    o = world.outcomes[-1]
    assert (o.success, o.actions, o.cost) == (False, 64, 64 * 25)
    assert world.task is None
    with pytest.raises(DomainError, match="no open task"):
        world.act(there)


def test_success_applies_consumption(two_room):
    m = two_room
    world = PersistentWorld(m, reset_seed=0)
    world.state = m.init
    task = m.tasks.get("serve-water(servingtable)")
    world.begin(task)
    plan = optimal_plan(BatchedModel(m), world.state, task).plan
    steps = [world.act(a) for a in plan]
    assert steps[-1].completed and world.outcomes[-1].cost == START_COSTS[task.name] and world.outcomes[-1].success
    atoms = set(m.true_atoms(world.state))
    assert ("at", "cup_0", "servingtable") in atoms and ("has-water", "cup_0") not in atoms
    assert not task.satisfied(world.state)  # needs real preparation again


def test_inapplicable_action_leaves_world_unchanged(two_room):
    m = two_room
    world = PersistentWorld(m, reset_seed=0)
    world.begin(m.tasks.get("serve-water(servingtable)"))
    before = world.state
    with pytest.raises(DomainError, match="not applicable"):
        world.act(m.action("fill(cup_0, water_fountain, fountain)"))
    assert world.state == before and world._actions == 0


def test_draw_tasks_is_seeded(three_room):
    a = [t.name for t in draw_tasks(three_room, 5, 50)]
    assert a == [t.name for t in draw_tasks(three_room, 5, 50)]
    assert a != [t.name for t in draw_tasks(three_room, 6, 50)]


def test_stream_resets_every_n_tasks(two_room):
    stream = TaskStream(two_room, seed=0)
    resets = [stream.next()[1] is not None for _ in range(120)]
    assert [i for i, r in enumerate(resets) if r] == [0, 50, 100]

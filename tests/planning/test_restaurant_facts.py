"""The facts of shared/restaurant.md, checked through the compiled model."""

import numpy as np
import pytest

from planning.domain.factored import factored_actions
from planning.world.task_stream import PersistentWorld
from tests.conftest import run_plan

HOPS = {
    "countertop": [0, 1, 2, 1, 8, 9, 35],
    "coffeemachine": [1, 0, 1, 2, 7, 8, 35],
    "dishwasher": [2, 1, 0, 3, 8, 9, 35],
    "shelf": [1, 2, 3, 0, 7, 8, 35],
    "servingtable": [8, 7, 8, 7, 0, 2, 35],
    "fountain": [9, 8, 9, 8, 2, 0, 35],
    "pantry": [35] * 6 + [0],
}
LOCS = list(HOPS)


def cost(model, name):
    return model.action_cost[model.action(name)]


def test_specific_action_costs(three_room):
    m = three_room
    assert cost(m, "move(countertop, fountain)") == 225  # kitchen -> fountain
    assert cost(m, "fill(cup_0, water_fountain, fountain)") == 1000
    assert cost(m, "refill-water(cup_0, jar_0, servingtable)") == 50
    assert cost(m, "pick(jar_0, pantry)") == 100
    assert cost(m, "place(jar_0, servingtable)") == 100
    assert cost(m, "wash(bowl_0, dishwasher)") == 200
    assert cost(m, "drain(cup_1, water_fountain, fountain)") == 50
    assert cost(m, "pour(cup_0, water_machine, coffeemachine)") == 200
    assert cost(m, "make-coffee(cup_0, water_machine, coffeemachine)") == 50
    assert cost(m, "make-fruit-bowl(apple_0, bowl_0, knife_0, countertop)") == 100


@pytest.mark.parametrize("layout,n", [("two-room", 6), ("three-room", 7)])
def test_every_move_costs_25_per_hop(layout, n, two_room, three_room):
    m = two_room if layout == "two-room" else three_room
    moves = {m.actions[a]: m.action_cost[a] for a in range(m.n_actions) if m.action_schema[a] == "move"}
    expected = {f"move({a}, {b})": 25 * HOPS[a][LOCS.index(b)] for a in LOCS[:n] for b in LOCS[:n] if a != b}
    assert moves == expected  # and no move to the same place


def test_action_schemas_and_counts(restaurant):
    schemas = {restaurant.action_schema[a] for a in range(restaurant.n_actions)}
    assert schemas == {
        "move",
        "pick",
        "place",
        "wash",
        "fill",
        "drain",
        "pour",
        "make-coffee",
        "make-fruit-bowl",
        "refill-water",
    }


def test_start_state(restaurant):
    m = restaurant
    jar = "shelf" if m.layout == "two-room" else "pantry"
    expected = {
        ("robot-at", "countertop"),
        ("hand-free",),
        ("at", "cup_0", "countertop"),
        ("at", "cup_1", "dishwasher"),
        ("dirty", "cup_1"),
        ("at", "water_fountain", "fountain"),
        ("at", "water_machine", "coffeemachine"),
        ("at", "apple_0", "countertop"),
        ("at", "bowl_0", "countertop"),
        ("at", "knife_0", "countertop"),
        ("at", "jar_0", jar),
        ("at", "plate_0", "servingtable"),
    }
    assert set(m.true_atoms(m.init)) == expected
    assert m.objects[m.objects.index("cup_0") :] == [
        "cup_0",
        "cup_1",
        "water_fountain",
        "water_machine",
        "apple_0",
        "bowl_0",
        "knife_0",
        "jar_0",
        "plate_0",
    ]


@pytest.mark.parametrize("layout,count", [("two-room", 42), ("three-room", 48)])
def test_task_instantiations_and_probabilities(layout, count, two_room, three_room):
    m = two_room if layout == "two-room" else three_room
    assert len(m.tasks) == count
    assert m.tasks.probabilities.sum() == pytest.approx(1.0, abs=1e-12)
    by_type = {}
    for t in m.tasks:
        by_type[t.type] = by_type.get(t.type, 0) + t.probability
    assert by_type == pytest.approx(
        {"serve-water": 0.25, "make-coffee": 0.30, "wash": 0.30, "clear": 0.05, "fruit-bowl": 0.05, "pick-place": 0.05}
    )
    n_loc = 6 if layout == "two-room" else 7
    assert m.tasks.get("pick-place(jar_0, servingtable)").probability == pytest.approx(0.05 / 6 / n_loc)
    assert m.tasks.get("wash(knives)").probability == pytest.approx(0.15)
    picks = {t.args[0] for t in m.tasks if t.type == "pick-place"}
    assert picks == {"cup_0", "cup_1", "bowl_0", "knife_0", "jar_0", "plate_0"}


def test_sampling_follows_the_distribution(two_room):
    rng = np.random.default_rng(7)
    draws = [two_room.tasks.sample(rng).type for _ in range(20000)]
    assert draws.count("serve-water") / 20000 == pytest.approx(0.25, abs=0.01)
    assert draws.count("wash") / 20000 == pytest.approx(0.30, abs=0.01)


def test_serve_water_consumption_empties_first_cup_only(two_room):
    m = two_room
    t = m.tasks.get("serve-water(servingtable)")
    s = m.state_from_atoms(
        [
            "(robot-at servingtable)",
            "(hand-free)",
            "(at cup_0 servingtable)",
            "(has-water cup_0)",
            "(at cup_1 servingtable)",
            "(has-water cup_1)",
        ]
    )
    after = set(m.true_atoms(t.consume(s)))
    assert ("has-water", "cup_0") not in after and ("has-water", "cup_1") in after
    assert ("at", "cup_0", "servingtable") in after and ("dirty", "cup_0") not in after


def test_make_coffee_consumption_leaves_cup_dirty(two_room):
    m = two_room
    t = m.tasks.get("make-coffee(servingtable)")
    s = m.state_from_atoms(
        ["(robot-at servingtable)", "(hand-free)", "(at cup_1 servingtable)", "(has-coffee cup_1)", "(dirty cup_1)"]
    )
    assert t.satisfied(s)
    after = set(m.true_atoms(t.consume(s)))
    assert {("at", "cup_1", "servingtable"), ("dirty", "cup_1")} <= after
    assert ("has-coffee", "cup_1") not in after and not t.satisfied(t.consume(s))


def test_fruit_bowl_consumption_takes_apple_out(two_room):
    m = two_room
    t = m.tasks.get("fruit-bowl(servingtable)")
    s = m.state_from_atoms(
        ["(robot-at servingtable)", "(hand-free)", "(at bowl_0 servingtable)", "(in apple_0 bowl_0)", "(dirty bowl_0)"]
    )
    after = set(m.true_atoms(t.consume(s)))
    assert {("at", "apple_0", "servingtable"), ("at", "bowl_0", "servingtable"), ("dirty", "bowl_0")} <= after
    assert ("in", "apple_0", "bowl_0") not in after


def test_goals_of_other_task_types(two_room):
    m = two_room
    s = m.init
    assert not m.tasks.get("clear(servingtable)").satisfied(s)  # the plate is there
    s2, _ = run_plan(m, s, ["move(countertop, servingtable)", "pick(plate_0, servingtable)"])
    assert m.tasks.get("clear(servingtable)").satisfied(s2)  # held is not "at"
    clean = m.reset_state(3)
    assert m.tasks.get("wash(bowls)").satisfied(clean) != (("dirty", "bowl_0") in m.true_atoms(clean))
    assert m.tasks.get("pick-place(plate_0, servingtable)").satisfied(s)
    held, _ = run_plan(m, s, ["pick(cup_0, countertop)"])
    assert not m.tasks.get("pick-place(bowl_0, countertop)").satisfied(held)  # hand not free


def test_already_satisfied_task_completes_at_zero_cost(two_room):
    world = PersistentWorld(two_room, reset_seed=0)
    world.state = two_room.init
    assert world.begin(two_room.tasks.get("pick-place(plate_0, servingtable)"))
    o = world.outcomes[-1]
    assert (o.cost, o.actions, o.success, o.auto) == (0, 0, True, True)
    assert world.state == two_room.init


def test_reference_figures(three_room):
    m = three_room
    _, fetch = run_plan(
        m,
        m.init,
        [
            "move(countertop, pantry)",
            "pick(jar_0, pantry)",
            "move(pantry, fountain)",
            "fill(jar_0, water_fountain, fountain)",
            "move(fountain, servingtable)",
            "place(jar_0, servingtable)",
        ],
    )
    assert fetch == 3000
    s, direct = run_plan(
        m,
        m.init,
        [
            "pick(cup_0, countertop)",
            "move(countertop, fountain)",
            "fill(cup_0, water_fountain, fountain)",
            "move(fountain, servingtable)",
            "place(cup_0, servingtable)",
        ],
    )
    assert direct == 1475 and m.tasks.get("serve-water(servingtable)").satisfied(s)
    jar_ready = m.state_from_atoms(
        [
            "(robot-at countertop)",
            "(hand-free)",
            "(at cup_0 countertop)",
            "(at jar_0 servingtable)",
            "(has-water jar_0)",
        ]
    )
    s, with_jar = run_plan(
        m,
        jar_ready,
        [
            "pick(cup_0, countertop)",
            "move(countertop, servingtable)",
            "refill-water(cup_0, jar_0, servingtable)",
            "place(cup_0, servingtable)",
        ],
    )
    assert with_jar == 450 and ("has-water", "jar_0") in m.true_atoms(s)  # the jar is not used up


def test_pour_water_restores_machine_water(two_room):
    m = two_room
    s = m.state_from_atoms(["(robot-at coffeemachine)", "(holding cup_0)", "(has-water cup_0)"])
    after = set(m.true_atoms(m.apply(s, m.action("pour(cup_0, water_machine, coffeemachine)"))))
    assert ("at", "water_machine", "coffeemachine") in after and ("has-water", "cup_0") not in after
    s = m.state_from_atoms(["(robot-at coffeemachine)", "(holding cup_0)", "(has-coffee cup_0)"])
    after = set(m.true_atoms(m.apply(s, m.action("pour(cup_0, water_machine, coffeemachine)"))))
    assert ("at", "water_machine", "coffeemachine") not in after and ("has-coffee", "cup_0") not in after


def test_make_coffee_uses_up_machine_water_and_needs_a_placed_vessel(two_room):
    m = two_room
    s, _ = run_plan(m, m.init, ["pick(cup_0, countertop)", "move(countertop, coffeemachine)"])
    make = m.action("make-coffee(cup_0, water_machine, coffeemachine)")
    assert not m.is_applicable(s, make)  # held, not placed
    s, _ = run_plan(m, s, ["place(cup_0, coffeemachine)", "make-coffee(cup_0, water_machine, coffeemachine)"])
    atoms = set(m.true_atoms(s))
    assert {("has-coffee", "cup_0"), ("dirty", "cup_0")} <= atoms
    assert ("at", "water_machine", "coffeemachine") not in atoms
    assert not any(m.action_schema[a] == "make-coffee" for a in m.applicable(s))
    assert "make-coffee(jar_0, water_machine, coffeemachine)" not in m.action_index  # no jar coffee


def test_apple_travels_inside_the_bowl(two_room):
    m = two_room
    s = m.state_from_atoms(["(robot-at countertop)", "(hand-free)", "(at bowl_0 countertop)", "(in apple_0 bowl_0)"])
    s, _ = run_plan(m, s, ["pick(bowl_0, countertop)", "move(countertop, servingtable)", "place(bowl_0, servingtable)"])
    assert m.tasks.get("fruit-bowl(servingtable)").satisfied(s)
    assert "pick(apple_0, servingtable)" not in [m.actions[a] for a in m.applicable(s)]


def test_world_reset_randomness(two_room):
    dirty_bowl = dirty_knife = 0
    for seed in range(2000):
        atoms = set(two_room.true_atoms(two_room.reset_state(seed)))
        dirty_bowl += ("dirty", "bowl_0") in atoms
        dirty_knife += ("dirty", "knife_0") in atoms
    assert dirty_bowl / 2000 == pytest.approx(0.6, abs=0.03)
    assert dirty_knife / 2000 == pytest.approx(0.6, abs=0.03)
    assert two_room.reset_state(11) == two_room.reset_state(11)


def test_factored_actions_follow_table_a1(three_room):
    f = factored_actions(three_room)
    assert f.heads == ["type", "thing1", "location", "thing2"]
    assert [len(v) for v in f.vocab] == [10, 10, 8, 10]  # O + 1 and L + 1 with the none slots
    label = lambda name: f.label(three_room.action(name))
    assert label("move(countertop, pantry)") == ("move", "none", "pantry", "none")
    assert label("place(cup_0, servingtable)") == ("place", "none", "servingtable", "none")
    assert label("pour(cup_0, water_machine, coffeemachine)") == ("pour", "cup_0", "none", "none")
    assert label("make-fruit-bowl(apple_0, bowl_0, knife_0, countertop)") == (
        "make-fruit-bowl",
        "apple_0",
        "none",
        "bowl_0",
    )
    assert label("refill-water(cup_1, jar_0, fountain)") == ("refill-water", "cup_1", "none", "jar_0")


def test_rooms_and_coordinates_are_declared(restaurant):
    cfg = restaurant.config
    rooms = cfg["layouts"][restaurant.layout]["rooms"]
    placed = sorted(l for ls in rooms.values() for l in ls)
    assert placed == sorted(restaurant.objects_of("location"))
    assert all(l in cfg["coordinates"] for l in placed)

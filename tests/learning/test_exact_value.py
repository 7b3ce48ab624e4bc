"""The exact value of the minimal grid (thesis §5.1) and the Bellman–Novelty search guided by it."""

import copy

import numpy as np
import pytest

from experiments.minimal_example import FIRST, exact_placement_q, placement_state
from learning.values.exact import ExactValue, reset_states
from planning.errors import DomainError
from planning.search.bellman_novelty import bellman_novelty_search
from planning.search.optimal import uniform_cost_search
from planning.value import Value, ZeroValue


@pytest.fixture(scope="module")
def exact(minimal):
    return {h: ExactValue(minimal, h) for h in ("myopic", "anticipatory")}


def test_state_space_and_protocol(minimal, exact):
    assert len(reset_states(minimal)) == 25  # the robot's start cell
    ev = exact["anticipatory"]
    assert len(ev.states) == 100  # 25 cells x apple on a, b, c or held
    assert isinstance(ev, Value) and ev.gamma == 0.99 and ev.r_goal == 10 and ev.scale == 1


@pytest.mark.parametrize("horizon", ["myopic", "anticipatory"])
@pytest.mark.parametrize("cell", ["a", "b"])
def test_agrees_with_exact_placement_q(minimal, exact, horizon, cell):
    m, ev = minimal, exact[horizon]
    s, clear = placement_state(m, cell), m.tasks.get(FIRST)
    want = exact_placement_q(m, cell, ev.gamma, ev.r_goal, ev.scale, horizon)
    assert ev.q(s, clear, m.action(f"place(apple, {cell})")) == pytest.approx(want, abs=1e-9)
    assert ev.q_max([s], clear)[0] == pytest.approx(want, abs=1e-9)  # placing is the best action there


def test_placement_values(minimal, exact):
    m = minimal
    clear = m.tasks.get(FIRST)
    gap = {
        h: exact[h].q_max([placement_state(m, "b")], clear)[0] - exact[h].q_max([placement_state(m, "a")], clear)[0]
        for h in exact
    }
    assert gap["myopic"] == pytest.approx(0.0)  # -1 + 10 either way
    # B: 0.8 * 10 + 0.2 * V(deliver A from B); A: 0.2 * 10 + 0.8 * V(deliver B from A); six steps each
    six = -sum(0.99**k for k in range(6)) + 0.99**5 * 10
    assert gap["anticipatory"] == pytest.approx(0.99 * (0.8 * 10 + 0.2 * six - 0.2 * 10 - 0.8 * six))
    assert gap["anticipatory"] == pytest.approx(3.7672, abs=1e-4)


def test_a_satisfied_task_is_auto_completed(minimal, exact):
    m, ev = minimal, exact["anticipatory"]
    on_b = m.state_from_atoms(["(robot-at b)", "(hand-free)", "(at apple b)"])
    deliver_b, deliver_a = m.tasks.get("deliver(b)"), m.tasks.get("deliver(a)")
    assert ev.q(on_b, deliver_b, None) == ev.q_max([on_b], deliver_b)[0] == 10  # the last task: terminal
    with pytest.raises(DomainError):
        ev.q(on_b, deliver_b, m.action("pick(apple, b)"))  # AUTO is the only valid action
    assert ev.v_ap([on_b])[0] == pytest.approx(0.8 * 10 + 0.2 * ev.q_max([on_b], deliver_a)[0])


def test_continuing_stream_bootstraps_across_tasks(minimal):
    m = copy.copy(minimal)
    m.config = {**minimal.config, "stream": {**minimal.config["stream"], "terminal_reset": False}}
    ev = ExactValue(m, "anticipatory")
    on_b = m.state_from_atoms(["(robot-at b)", "(hand-free)", "(at apple b)"])
    deliver_b = m.tasks.get("deliver(b)")
    # AUTO: R_goal, the (empty) consumption, then γ V_AP of what is left, as the trainer's AUTO transition
    assert ev.q(on_b, deliver_b, None) == pytest.approx(10 + 0.99 * ev.v_ap([deliver_b.consume(on_b)])[0])
    # the Bellman equation holds everywhere: V = max over the applicable actions of Q
    rng = np.random.default_rng(0)
    for i in rng.choice(len(ev.states), 20, replace=False):
        s = ev.states[i]
        for t in m.tasks:
            if t.satisfied(s):
                continue
            best = max(ev.q(s, t, a) for a in m.applicable(s))
            assert ev.q_max([s], t)[0] == pytest.approx(best, abs=1e-8)


def search(m, value, beta):
    s, clear = placement_state(m, "x1y2"), m.tasks.get(FIRST)  # A is 3 moves away, B 5
    ref = uniform_cost_search(m, s, clear)
    assert ref.cost == 4
    r = bellman_novelty_search(m, s, clear, value, budget=2000, beta=beta, reference_plan=ref.plan)
    end = s
    for a in r.plan:
        end = m.apply(end, a)
    assert clear.satisfied(end)
    where = next(c for c in ("a", "b", "c") if end & m.state_from_atoms([f"(at apple {c})"]))
    return where, r.stats


def test_search_with_the_exact_value_leaves_the_apple_on_b(minimal, exact):
    where, st = search(minimal, exact["anticipatory"], beta=1.5)  # 6 <= 1.5 * 4
    assert (where, st.cost, st.c_myo, st.source) == ("b", 6, 4, "search")
    assert st.v_ap == pytest.approx(
        exact["anticipatory"].v_ap([minimal.state_from_atoms(["(robot-at b)", "(hand-free)", "(at apple b)"])])[0]
    )


def test_search_keeps_to_the_bound_and_zero_value_takes_the_cheaper(minimal, exact):
    where, st = search(minimal, exact["anticipatory"], beta=1.25)  # 6 > 5: B not eligible
    assert (where, st.cost) == ("a", 4)
    where, st = search(minimal, ZeroValue(0.99), beta=3.0)
    assert (where, st.cost) == ("a", 4)

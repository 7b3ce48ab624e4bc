"""The thesis's minimal example (§5.1) runs through the same compiler with no Python of its own."""

from planning.domain.factored import factored_actions
from planning.search.optimal import uniform_cost_search
from planning.world.task_stream import PersistentWorld, TaskStream


def test_model_and_tasks(minimal):
    m = minimal
    assert m.n_actions == 80 + 3 + 3  # 80 grid moves, pick and place at each receptacle
    probs = {t.name: t.probability for t in m.tasks}
    assert probs == {"clear(c)": 0.0, "deliver(b)": 0.8, "deliver(a)": 0.2}
    assert factored_actions(m).heads == ["type", "cell", "thing"]


def test_episode_is_clear_then_a_drawn_delivery(minimal):
    stream = TaskStream(minimal, seed=3)
    episodes = [(stream.next(), stream.next()) for _ in range(200)]
    assert all(first[0].name == "clear(c)" and first[1] is not None for first, _ in episodes)
    seconds = [second[0].name for _, second in episodes]
    assert 0.7 < seconds.count("deliver(b)") / 200 < 0.9
    starts = {minimal.true_atoms(minimal.reset_state(first[1]))[0] for first, _ in episodes}
    assert len(starts) > 15  # the robot starts on a random cell


def test_placing_on_b_presatisfies_delivery(minimal):
    m = minimal
    s = m.state_from_atoms(["(robot-at c)", "(hand-free)", "(at apple c)"])
    plan = uniform_cost_search(m, s, m.tasks.get("clear(c)"))
    assert plan.cost == 1 + 6 + 1  # pick, six moves to a or b, place
    s_b = m.state_from_atoms(["(robot-at b)", "(hand-free)", "(at apple b)"])
    world = PersistentWorld(m)
    world.state = s_b
    assert world.begin(m.tasks.get("deliver(b)"))  # satisfied at no cost
    assert world.outcomes[-1].cost == 0
    assert uniform_cost_search(m, s_b, m.tasks.get("deliver(a)")).cost == 1 + 4 + 1

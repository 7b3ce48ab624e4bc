"""β selection reports the development and held-out splits apart, each against the myopic oracle."""

from experiments.select_beta import split_costs


def test_split_costs_separate_development_from_held_out(two_room):
    per_sequence = [{"id": i, "cost": 1000 * (i + 1), "tasks": 50, "successes": 50 - (i == 3)} for i in range(10)]
    s = split_costs(two_room, {"per_sequence": per_sequence})
    assert s["development"]["sequences"] == [1, 3, 6] and s["development"]["tasks"] == 150
    assert s["development"]["cost_per_task"] == round((2000 + 4000 + 7000) / 150, 2)
    assert s["development"]["success_rate"] == round(149 / 150, 4)
    assert s["held-out"]["sequences"] == [0, 2, 4, 5, 7, 8, 9] and s["held-out"]["tasks"] == 350

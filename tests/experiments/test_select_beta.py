"""β selection reports the development and held-out splits apart, each against the myopic oracle."""

from experiments.select_beta import split_costs


def test_split_costs_separate_development_from_held_out(two_room):
    per_sequence = [{"id": i, "cost": 1000 * (i + 1), "tasks": 50, "successes": 50 - (i == 3)} for i in range(10)]
    s = split_costs(two_room, {"per_sequence": per_sequence})
    assert s["development"]["sequences"] == [1, 3, 6] and s["development"]["tasks"] == 150
    assert s["development"]["cost_per_task"] == round((2000 + 4000 + 7000) / 150, 2)
    assert s["development"]["success_rate"] == round(149 / 150, 4)
    assert s["held-out"]["sequences"] == [0, 2, 4, 5, 7, 8, 9] and s["held-out"]["tasks"] == 350


def test_split_costs_give_the_improvement_as_a_number(two_room):
    """Against the committed myopic oracle file: (C_oracle − C) / C_oracle of each split, a float."""
    import json
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    ref = json.loads((root / "results" / "myopic-oracle-two-room.json").read_text())["per_sequence"]
    s = split_costs(two_room, {"per_sequence": ref})  # the oracle itself: 0 on both splits
    assert s["development"]["improvement_vs_myopic"] == 0.0 and "improvement_note" not in s["development"]
    half = [{**r, "cost": r["cost"] / 2} for r in ref]
    assert s["held-out"]["improvement_vs_myopic"] == 0.0
    assert split_costs(two_room, {"per_sequence": half})["development"]["improvement_vs_myopic"] == 0.5

"""β selection reports the development and held-out splits apart, each against the myopic oracle."""

import pytest

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


def test_the_candidates_files_are_named_as_the_agents_own(tmp_path, monkeypatch):
    """On a domain other than the restaurant every β's development file starts with the domain's name, as
    `experiments.evaluate` names the guided agent's files (`planning.world.results.default_out`)."""
    import json
    import shutil
    import sys
    from pathlib import Path

    import torch

    from experiments import select_beta
    from learning.encoding import Encoding
    from learning.q.checkpoints import network_payload
    from learning.q.network import build_network
    from planning import cli
    from planning.atomic import write_json
    from planning.domain.compiler import compile_domain
    from planning.world.sequences import generate, sequence_dir

    root = Path(__file__).resolve().parents[2]
    shutil.copytree(root / "domains" / "minimal", tmp_path / "minimal", ignore=shutil.ignore_patterns("sequences"))
    monkeypatch.chdir(tmp_path)
    model = compile_domain("minimal", "grid")
    for rec in generate(model, length=4):
        write_json(sequence_dir(model) / f"seq-{rec['id']:02d}.json", rec)
    enc = Encoding(model)
    torch.manual_seed(0)
    cfg = {"horizon": "anticipatory", "layout": "grid", "seed": 0, "gamma": 0.97, "goal_reward": 10.0}
    torch.save(network_payload(build_network(enc, 8), enc, {"config": cfg}), "v.pt")
    argv = ["select_beta", "--domain", "minimal", "--checkpoint", "v.pt", "--betas", "1,2", "--budget", "50"]
    monkeypatch.setattr(sys, "argv", [*argv, "--no-final"])
    cli.run(select_beta.main)
    chosen = json.loads(Path("results/beta-selection-v.json").read_text())
    files = [c["file"] for c in chosen["candidates"]]
    assert [Path(f).name.startswith("minimal-rl-guided-") for f in files] == [True, True]
    assert all(Path(f).is_file() for f in files) and chosen["chosen_beta"] in (1.0, 2.0)
    # the same selection again is played from its files and rewritten; one with other candidates is refused
    cli.run(select_beta.main)
    monkeypatch.setattr(sys, "argv", [*argv[:-4], "--betas", "1,3", "--budget", "50", "--no-final"])
    with pytest.raises(SystemExit) as e:
        cli.run(select_beta.main)
    assert e.value.code == 2
    assert json.loads(Path("results/beta-selection-v.json").read_text())["candidates"] == chosen["candidates"]

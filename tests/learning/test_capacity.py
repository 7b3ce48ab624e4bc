"""The capacity check: its Q* labels, its best-action measure, and its command's results file."""

import json
import sys

import numpy as np
import pytest

from learning import capacity
from learning.capacity import Labeller, best_is_optimal
from planning.domain.compiler import compile_domain
from planning.errors import DomainError

GAMMA, R_GOAL = 0.97, 30.0


@pytest.fixture(scope="module")
def blockworld():
    return compile_domain("domains/blockworld", "grid7x7")


def test_q_star_one_action_from_the_goal(blockworld):
    """Holding d at orange: placing it completes one-block(d_orange) (-1 + R_goal); a move of 50 to green is
    followed by the move back (50) and the place, discounted per action."""
    m = blockworld
    task = m.tasks.get("one-block(d_orange)")
    lab = Labeller(m, GAMMA, R_GOAL)
    v, plan = lab.plan(m.init, task)
    assert [m.actions[a] for a in plan] == [
        "move(pink, green)",
        "pick(d, green)",
        "move(green, orange)",
        "place(d, orange)",
    ]
    assert v == pytest.approx(-1 + GAMMA * (-1 + GAMMA * (-0.5 + GAMMA * (-1 + R_GOAL))))
    s = m.init
    for a in plan[:-1]:
        s = m.apply(s, a)
    q = {m.actions[a]: value for a, value in lab.q_star(s, task)}
    assert len(q) == 10  # nine moves and the place
    assert q["place(d, orange)"] == pytest.approx(-1 + R_GOAL)
    assert q["move(orange, green)"] == pytest.approx(-0.5 + GAMMA * (-0.5 + GAMMA * (-1 + R_GOAL)))
    assert q["move(orange, red)"] == pytest.approx(-1.5 + GAMMA * (-1.5 + GAMMA * (-1 + R_GOAL)))
    assert max(q, key=q.get) == "place(d, orange)"


def test_best_is_optimal_counts_pairs_and_ties():
    pair = np.array([0, 0, 0, 1, 1, 2, 2])
    target = np.array([1.0, 3.0, 2.0, 5.0, 5.0, 0.0, 1.0])
    q = np.array([0.0, 9.0, 1.0, 1.0, 2.0, 7.0, 6.0])  # pair 0 right, pair 1 a tie (right), pair 2 wrong
    assert best_is_optimal(q, target, pair) == pytest.approx(2 / 3)


def run(monkeypatch, *args):
    monkeypatch.setattr(
        sys, "argv", ["capacity", "--domain", "domains/blockworld", "--layout", "grid7x7", *map(str, args)]
    )
    capacity.main()


def test_the_command_writes_its_check_and_keeps_another_runs(monkeypatch, tmp_path):
    out = tmp_path / "cap.json"
    tiny = ("--states", 12, "--epochs", 2, "--hidden", 16, "--goal-reward", R_GOAL, "--out", out)
    run(monkeypatch, *tiny)
    r = json.loads(out.read_text())
    assert (r["domain"], r["layout"], r["r_goal"], r["cost_scale"]) == ("blockworld", "grid7x7", R_GOAL, 100.0)
    assert r["settings"]["states"] == 12 and [row["epoch"] for row in r["fit"]] == [1, 2]
    assert r["labelled_actions"] >= 12 * 2  # every state has a move and a pick or a place
    assert 0.0 <= r["fit"][-1]["held_out_best_optimal"] <= 1.0
    assert r["greedy"]["tasks"] == 100 and 0.0 <= r["greedy"]["success_rate"] <= 1.0
    assert r["provenance"]["command"]
    with pytest.raises(DomainError, match="settings"):
        run(monkeypatch, *tiny[:-2], "--epochs", 3, "--out", out)  # another configuration: refused
    assert json.loads(out.read_text()) == r
    run(monkeypatch, *tiny, "--epochs", 3, "--force")
    assert [row["epoch"] for row in json.loads(out.read_text())["fit"]] == [1, 2, 3]


def test_a_trained_checkpoint_is_scored_against_the_labels(blockworld, monkeypatch, tmp_path):
    """--score: a myopic checkpoint's Q against labels made with its discount and R_goal; the file names its run
    and the domain report lists it. An anticipatory checkpoint is refused (its Q is not the myopic Q*)."""
    import torch

    from experiments.report.domain import scored_checkpoints
    from learning.encoding import Encoding
    from learning.q.checkpoints import network_payload
    from learning.q.network import build_network
    from learning.q.value import value_function
    from learning.reward import cost_scale

    enc = Encoding(blockworld, "arguments+objects")
    torch.manual_seed(0)
    cfg = {"horizon": "myopic", "layout": "grid7x7", "seed": 3, "gamma": GAMMA, "goal_reward": R_GOAL}
    cfg["task_features"] = "arguments+objects"
    ckpt, out = tmp_path / "m.pt", tmp_path / "results" / "blockworld-capacity-score-m.json"
    out.parent.mkdir()
    torch.save(network_payload(build_network(enc, 16), enc, {"config": cfg, "step": 1234}), ckpt)
    run(monkeypatch, "--score", ckpt, "--states", 12, "--out", out)
    r = json.loads(out.read_text())
    labels = Labeller(blockworld, GAMMA, R_GOAL).visit(12, 0, 0.3, 20)
    assert r["run"] == "myopic-grid7x7-seed3-features-objects" and r["checkpoint_step"] == 1234
    assert r["scored"]["pairs"] == 12 and r["scored"]["mean_q_star"] == round(float(labels["q"].mean()), 4)
    assert 0.0 <= r["scored"]["best_optimal"] <= 1.0 and r["greedy"]["tasks"] == 100
    # the greedy figure is the run's own trainer check: its evaluation stream is 10,000 + its seed
    vf = value_function(torch.load(ckpt, weights_only=True), blockworld, ckpt)
    own = capacity.greedy_evaluation(vf, blockworld, 10_003, 100, GAMMA, R_GOAL, cost_scale(blockworld))
    assert r["greedy"]["stream_seed"] == 10_003 and r["greedy"]["cost_per_task"] == own["cost_per_task"]
    with pytest.raises(DomainError, match="settings"):
        run(monkeypatch, "--score", ckpt, "--states", 14, "--out", out)
    torch.save(network_payload(build_network(enc, 16), enc, {"config": {**cfg, "horizon": "anticipatory"}}), ckpt)
    with pytest.raises(DomainError, match="trained for the anticipatory horizon: --score compares with the myopic Q"):
        run(monkeypatch, "--score", ckpt, "--states", 12, "--out", out, "--force")
    monkeypatch.chdir(tmp_path)
    lines = scored_checkpoints("blockworld")
    assert lines[-1].startswith(
        "| grid7x7 | myopic-grid7x7-seed3-features-objects, step 1,234 | arguments+objects | 12 |"
    )
    assert scored_checkpoints("restaurant") == []

"""Every planning tool on the second real domain, the persistent blockworld (issue 37), with tiny settings, one
command after another as their inputs need: the checker, the sequences' check, the oracles and the planner
benchmark. The GNN's tools are in test_blockworld_gnn.py and the learners in test_blockworld_learning.py (apart,
so that the three run on separate workers)."""

from tests.blockworld_copy import LAYOUT, ROOT, results, run


def test_every_planning_tool_runs_on_the_blockworld(bw):
    work, d = bw
    common = ("--domain", d, "--layout", LAYOUT)
    play = (*common, "--sequences", "0")  # the tiny canonical sequence
    run(work, "planning.world.domain_check", d, "--no-costs")
    run(work, "planning.world.sequences", "--domain", ROOT / "domains" / "blockworld", "--layout", LAYOUT, "--check")
    # the oracles: myopic (ours, optimal), clairvoyant K = 2, the labelling oracle's C_AP of the start state
    run(work, "oracles.myopic", *play, "--planner", "internal", "--out", "results/myopic.json")
    myopic = results(work, "myopic.json")
    assert myopic["success_rate"] == 1.0 and len(myopic["per_task"]) == 4
    run(work, "oracles.clairvoyant", *play, "--K", "2", "--out", "results/k2.json")
    assert results(work, "k2.json")["cost_per_task"] <= myopic["cost_per_task"]
    run(work, "oracles.labelling", *common, "--out", "results/label.json")
    # the planner benchmark
    run(work, "oracles.planner_bench", *common, "--calls", 2, "--out", "results/planner.json", "--time-limit", 60)

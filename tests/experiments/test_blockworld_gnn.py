"""The one-task GNN's tools on the second real domain, the persistent blockworld (issue 37), with tiny settings:
the augmented dataset (the faithful states with prepared ones), a model trained, exported and deployed both
ways (native selection and the value in the search)."""

from tests.blockworld_copy import LAYOUT, played, run


def test_the_gnn_builds_its_data_trains_and_plays_on_the_blockworld(bw):
    work, d = bw
    common = ("--domain", d, "--layout", LAYOUT)
    play = (*common, "--sequences", "0")
    data = ("--augmented", "--n-states", 4, "--n-prepared", 4, "--out", "runs/gnn-aug")
    run(work, "learning.gnn_dataset", *common, *data)
    run(work, "learning.gnn_train", *common, "--data", "runs/gnn-aug", "--epochs", 1, "--out", "runs/gnn")
    run(work, "learning.export", "runs/gnn", "--out", "checkpoints/gnn.pt", "--figures", "results/gnn-training.json")
    run(work, "experiments.evaluate", *play, "--agent", "gnn-native", "--model", "checkpoints/gnn.pt")
    run(work, "experiments.evaluate", *play, "--agent", "gnn-guided", "--model", "checkpoints/gnn.pt", "--budget", 30)
    played(work, ["gnn-guided", "gnn-native"])

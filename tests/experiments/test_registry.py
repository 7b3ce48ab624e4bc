"""Every registered agent builds from its own command-line options and plays a short sequence: a new row is covered here."""
import argparse

import pytest

from experiments.registry import AGENTS, agent_class, describe
from planning.errors import DomainError
from planning.world.runner import default_out, play_sequence
from planning.world.sequences import Sequence
from planning.world.task_stream import draw_tasks


@pytest.fixture(scope="module")
def checkpoint(minimal, tmp_path_factory):
    from learning.encoding import Encoding
    from learning.qnet import build_network, network_payload, save_checkpoint

    enc = Encoding(minimal)
    path = tmp_path_factory.mktemp("ckpt") / "rl-anticipatory-grid-seed0.pt"
    return str(save_checkpoint(path, network_payload(build_network(enc, 16), enc,
                                                     {"step": 1, "config": {"gamma": 0.99, "horizon": "anticipatory"}})))


@pytest.fixture(scope="module")
def gnn(minimal, tmp_path_factory):
    """A tiny untrained GNN checkpoint with the grid's node features."""
    from learning.gnn_model import GNNCostModel, save_gnn_checkpoint
    from learning.graph import GraphEncoder

    names = GraphEncoder(minimal).feature_names
    net = GNNCostModel(len(names), width=8)
    path = tmp_path_factory.mktemp("gnn") / "gnn-grid-seed0.pt"
    return str(save_gnn_checkpoint(path, {"model": net.state_dict(), "dims": net.dims, "feature_names": names,
                                          "layout": minimal.layout}))


ARGS = {"rl-greedy": ["--checkpoint", "{ckpt}"], "rl-guided": ["--checkpoint", "{ckpt}", "--budget", "50"],
        "clairvoyant": ["--K", "2", "--time-limit", "30"], "myopic-oracle": ["--planner", "internal"],
        "gnn-native": ["--model", "{gnn}", "--candidates", "{tmp}/candidates.jsonl"],
        "gnn-guided": ["--model", "{gnn}", "--budget", "50"]}


@pytest.mark.parametrize("name", list(AGENTS))
def test_agent_builds_from_its_options_and_plays(minimal, checkpoint, gnn, name, tmp_path):
    cls = agent_class(name)
    p = argparse.ArgumentParser()
    cls.options(p)
    args = p.parse_args([a.format(ckpt=checkpoint, gnn=gnn, tmp=tmp_path) for a in ARGS.get(name, [])])
    agent = cls.from_args(args, minimal)
    assert agent.name.startswith(name.split("-")[0]) and isinstance(agent.config, dict)
    assert default_out(agent, minimal).startswith("results/") and default_out(agent, minimal).endswith(".json")
    first = minimal.tasks.get("clear(c)")
    seq = Sequence(0, 3, [first] + draw_tasks(minimal, 5, 2))
    rows = play_sequence(minimal, agent, seq)
    assert [r["task"] for r in rows] == [t.name for t in seq.tasks]
    assert all(r["cost"] >= 0 and r["actions"] <= 64 for r in rows)
    if name != "random" and name != "rl-greedy":            # planners solve every task of the grid
        assert all(r["success"] for r in rows)


def test_list_agents_describes_every_row():
    text = describe()
    assert [line.split()[0] for line in text.splitlines()] == list(AGENTS)


def test_unknown_agent_is_a_one_line_error():
    with pytest.raises(DomainError, match="unknown agent 'greedy'"):
        agent_class("greedy")

"""Every registered agent builds from its own command-line options and plays a short sequence: a new row is covered here."""

import argparse
import dataclasses

import pytest

from experiments.registry import AGENTS, agent_class, agent_options, describe, options_class
from planning.errors import DomainError
from planning.world.agents import Agent, Planner, Policy
from planning.world.results import default_out
from planning.world.runner import play_sequence
from planning.world.sequences import Sequence
from planning.world.task_stream import draw_tasks

ARGS = {
    "rl-greedy": ["--checkpoint", "{ckpt}"],
    "rl-guided": ["--checkpoint", "{ckpt}", "--budget", "50"],
    "clairvoyant": ["--K", "2", "--time-limit", "30"],
    "myopic-oracle": ["--planner", "internal"],
    "gnn-native": ["--model", "{gnn}", "--candidates", "{tmp}/candidates.jsonl"],
    "gnn-guided": ["--model", "{gnn}", "--budget", "50"],
}


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
    if name != "random" and name != "rl-greedy":  # planners solve every task of the grid
        assert all(r["success"] for r in rows)


def test_list_agents_describes_every_row():
    text = describe()
    assert [line.split()[0] for line in text.splitlines()] == list(AGENTS)


def test_unknown_agent_is_a_one_line_error():
    with pytest.raises(DomainError, match="unknown agent 'greedy'"):
        agent_class("greedy")


HOOKS = ("options", "from_args", "start", "summary", "set_log")


@pytest.mark.parametrize("name", list(AGENTS))
def test_every_agent_provides_the_protocol_the_runner_and_registry_call(minimal, checkpoint, gnn, name, tmp_path):
    """Each hook the command, the registry, the workers and the runner call is declared by the protocol
    (`planning.world.agents.Agent`), with its contract, and provided by every registered class: its own
    options and builder, and once built a name, a run name and a config of its own, a summary of extra keys."""
    cls = agent_class(name)
    assert issubclass(cls, (Planner, Policy))
    for hook in (*HOOKS, "keeps_log", "run_name", "name", "config"):
        assert hasattr(Agent, hook), hook
    assert all((getattr(Agent, h).__doc__ or "").strip() for h in HOOKS)
    assert cls.from_args.__func__ is not Agent.from_args.__func__
    assert cls.options.__func__ is not Agent.options.__func__
    assert (cls.__doc__ or "").strip()  # its --list-agents line
    given = {
        "checkpoint": checkpoint,
        "model": gnn,
        "budget": 50,
        "candidates": str(tmp_path / "c.jsonl"),
        "K": 2,
        "time_limit": 30.0,
        "planner": "internal",
    }
    declared = {f.name for f in dataclasses.fields(options_class(cls))}
    agent = cls.from_args(agent_options(cls, **{k: v for k, v in given.items() if k in declared}), minimal)
    assert isinstance(agent.name, str) and agent.name != Agent.name
    assert isinstance(agent.run_name, str) and agent.run_name != Agent.run_name
    assert isinstance(agent.config, dict) and agent.config and agent.config is not Agent.config
    assert isinstance(agent.summary([]), dict)
    assert agent.keeps_log is (name == "clairvoyant")


def test_agent_options_are_the_declared_flags_with_their_defaults():
    o = agent_options("rl-guided", checkpoint="x.pt", beta=1.5)
    assert (o.checkpoint, o.beta, o.budget, o.depth_cap, o.reference, o.time_limit) == (
        "x.pt",
        1.5,
        None,
        None,
        "internal",
        60.0,
    )
    assert agent_options("myopic-oracle") == agent_options("myopic-oracle", planner="fast-downward", time_limit=600.0)
    with pytest.raises(DomainError, match="--checkpoint"):
        agent_options("rl-greedy")
    with pytest.raises(DomainError, match="--layout"):
        agent_options("random", layout="two-room")

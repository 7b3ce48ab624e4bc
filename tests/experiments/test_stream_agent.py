"""The guided agent on a declared task stream with a distribution estimator (issue 38): V_AP under an
estimator's P, the compiled value's memo keeping distributions apart, and an evaluation on a stream's canonical
sequences that keeps its results apart. On the grid domain and a copy of it with two task types."""

import numpy as np
import pytest

from experiments.registry import agent_options, build
from learning.encoding import Encoding
from learning.q.checkpoints import network_payload, save_checkpoint
from learning.q.network import build_network
from learning.q.value import load_value_function
from oracles.command import RunOptions, play
from planning.atomic import write_json
from planning.world import sequences
from tests.learning.test_seeds import walk_states as walk
from tests.planning.test_streams import grid_with_streams


def tiny_checkpoint(model, path):
    import torch

    torch.manual_seed(0)
    enc = Encoding(model)
    payload = network_payload(build_network(enc, 16), enc, {"step": 1, "config": {"gamma": 0.99}})
    return str(save_checkpoint(path, payload))


def test_v_ap_follows_the_distribution_it_is_given(tmp_path):
    model = grid_with_streams(tmp_path)  # support: clear(c), deliver(a), deliver(b)
    vf = load_value_function(tiny_checkpoint(model, tmp_path / "q.pt"), model)
    states = walk(model, 40)
    q = np.stack([vf.q_max(states, t) for t in model.tasks], 1)  # (N, tasks)
    p1 = np.asarray(model.tasks.probabilities, float)
    p2 = np.array([0.8 if t.type == "clear" else 0.1 for t in model.tasks])
    native = vf.native
    for p in (p2, p1, p2):
        vf.set_distribution(p)
        assert np.allclose(vf.v_ap(states), q @ p, atol=1e-5)
        if native is not None:  # the compiled V_AP, memo and all: no value of another distribution returned
            assert np.allclose(native.v_ap(states), q @ p, atol=1e-5)
    vf.set_distribution(None)
    assert np.allclose(vf.v_ap(states), q @ (p1 / p1.sum()), atol=1e-5)
    with pytest.raises(Exception, match="zero off the support"):
        load_value_function(tiny_checkpoint(model, tmp_path / "q2.pt"), model).set_distribution(np.ones(1))


def test_the_guided_agent_plays_a_stream_with_an_estimator(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    model = grid_with_streams(tmp_path)
    for rec in sequences.generate(model, count=2, length=6, stream_name="alternate"):
        write_json(sequences.sequence_dir(model, "alternate") / f"seq-{rec['id']:02d}.json", rec)
    ckpt = tiny_checkpoint(model, tmp_path / "rl-anticipatory-grid-seed0.pt")
    opts = lambda **kw: agent_options("rl-guided", checkpoint=ckpt, budget=30, beta=2.0, **kw)
    run = RunOptions(progress=False, stream="alternate")
    r, out = play(model, build("rl-guided", opts(estimator="markov"), model), [0, 1], run)
    assert out.endswith("-stream-alternate.json") and "-est-markov" in out
    assert r["config"]["stream"] == "alternate" and r["config"]["estimator"]["name"] == "markov"
    seqs = sequences.load(model, [0, 1], "alternate")
    assert [row["task"] for row in r["per_task"]] == [t.name for s in seqs for t in s.tasks]
    # the same agent with the known P: its own file, the thesis's agent (no estimator in its config)
    r2, out2 = play(model, build("rl-guided", opts(), model), [0, 1], run)
    assert out2 != out and "estimator" not in r2["config"] and r2["config"]["stream"] == "alternate"
    for rec in sequences.generate(model, count=1, length=6):
        write_json(sequences.sequence_dir(model) / f"seq-{rec['id']:02d}.json", rec)
    with pytest.raises(Exception, match="needs a Markov stream"):
        play(model, build("rl-guided", opts(estimator="markov"), model), [0], RunOptions(progress=False))

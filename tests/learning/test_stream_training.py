"""The learner on a declared task stream with a distribution estimator (issue 38): the boundary target weighs
each completion's next tasks by P(τ' | the task completed); the known estimator is the thesis's target, bit
for bit; the estimate is checkpointed and resumed. On a copy of the grid domain with two task types."""

import numpy as np
import pytest
import torch

from learning.q.replay import COMPLETE, mixed_batch
from learning.q.targets import _pairs, td_targets
from learning.q.training import Trainer, bound_suffix
from planning.world.estimators import build
from tests.learning.test_dqn import small_config
from tests.planning.test_streams import grid_with_streams


def manual_boundary(online, target, enc, batch, gamma, estimator):
    """r + γ Σ_τ' P(τ' | τ) Q_target(s', τ', argmax_a Q_online(s', τ', a)) for the batch's completion rows."""
    comp = np.flatnonzero(batch["kinds"] == COMPLETE)
    obs, valid = _pairs(enc, batch["next_states"][comp])
    obs, valid = torch.from_numpy(obs), torch.from_numpy(valid)
    with torch.no_grad():
        best = online(obs, valid).argmax(1)
        q = target(obs, valid).gather(1, best[:, None])[:, 0].reshape(len(comp), len(enc.support)).double().numpy()
    tasks = enc.model.tasks
    p = np.stack([estimator.probabilities(tasks[int(t)])[enc.support] for t in batch["tasks"][comp]])
    return comp, batch["rewards"][comp] + gamma * (q * p).sum(1)


@pytest.fixture
def trained(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # the demonstrations' cache of this changed grid domain stays here
    model = grid_with_streams(tmp_path)
    cfg = small_config(
        model,
        tmp_path / "run",
        "anticipatory",
        steps=300,
        demo_tasks=30,
        hidden=32,
        stream="alternate",
        estimator="markov",
    )
    cfg.domain = str(model.folder)
    t = Trainer(cfg, progress=False)
    t.train()
    return model, t


def test_the_boundary_weighs_next_tasks_by_the_estimator(trained):
    model, t = trained
    batch = mixed_batch(t.memory, t.demos, 128, 1.0, np.random.default_rng(0))  # the demos: completions
    assert (batch["kinds"] == COMPLETE).sum() > 5
    y = td_targets(t.net, t.target, t.enc, batch, t.cfg.gamma, "anticipatory", estimator=t.estimator).numpy()
    comp, expect = manual_boundary(t.net, t.target, t.enc, batch, t.cfg.gamma, t.estimator)
    assert np.allclose(y[comp], expect, atol=1e-4)
    # the known estimator is the thesis's target exactly; the markov one differs from it
    known = td_targets(t.net, t.target, t.enc, batch, t.cfg.gamma, "anticipatory", estimator=build("known", model))
    plain = td_targets(t.net, t.target, t.enc, batch, t.cfg.gamma, "anticipatory")
    assert torch.equal(known, plain)
    assert not np.allclose(plain.numpy()[comp], expect, atol=1e-4)


def test_a_stream_run_keeps_its_files_apart_and_resumes_its_estimate(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    model = grid_with_streams(tmp_path)

    def cfg(steps):
        c = small_config(
            model,
            tmp_path / "run",
            "anticipatory",
            steps=steps,
            demo_tasks=0,
            hidden=32,
            stream="alternate",
            estimator="markov-empirical",
            estimator_forget=0.9,
        )
        c.domain = str(model.folder)
        return c

    assert bound_suffix(cfg(1)) == "-stream-alternate-est-markov-empirical-forget0.9"
    a = Trainer(cfg(200), progress=False)
    a.train()
    assert a.estimator.counts.sum() > 1  # transitions of the stream, learned online
    b = Trainer(cfg(300), progress=False)
    b.resume(tmp_path / "run" / "last.pt")
    assert np.array_equal(b.estimator.counts, a.estimator.counts)
    assert b.stream.previous is a.stream.previous
    a.cfg.steps = 300
    a.train()
    b.train()
    assert np.array_equal(b.estimator.counts, a.estimator.counts)
    assert np.array_equal(a.memory.tasks[:300], b.memory.tasks[:300])

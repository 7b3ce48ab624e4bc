"""Seeds trained together (`learning.q.seeds`): the batched evaluation equals each network's own, and a
batched run follows its single run (same exploration, same minibatches, same replay memory)."""

import numpy as np
import pytest
import torch

from learning.encoding import Encoding
from learning.q.network import build_network
from learning.q.seeds import Stack, pair_q
from learning.q.targets import _Pairs
from learning.q.training import Trainer, train_runs
from planning.errors import DomainError
from tests.learning.test_dqn import small_config


def walk_states(model, n, seed=0):
    rng, s, out = np.random.default_rng(seed), model.reset_state(seed), []
    for _ in range(n):
        out.append(s)
        acts = model.applicable(s)
        s = model.apply(s, int(acts[rng.integers(len(acts))]))
    return out


@pytest.mark.parametrize("features", ["arguments", "arguments+objects"])
def test_stacked_q_equals_each_networks_own(two_room, features):
    """pair_q of three networks with different weights and different row counts per seed equals each
    network's `_Pairs.values` (float32 rounding), padding and all; with the goal-object view too."""
    enc = Encoding(two_room, features)
    nets = []
    for seed in (0, 4, 8):
        torch.manual_seed(seed)
        nets.append(build_network(enc, 64))
    stack = Stack(nets, grad=False)
    items, expect = [], []
    for s, n in enumerate((40, 7, 0)):
        states = walk_states(two_room, max(n, 1), seed=s)[:n]
        packed = enc.pack(states) if n else np.zeros((0, enc.n_words), np.uint64)
        tasks = np.resize(enc.support, n).astype(np.int64)
        valid = enc.valid_for(packed, tasks) if n else np.zeros((0, enc.n_actions), bool)
        bits = enc.bm.to_bits(packed) if n else np.zeros((0, enc.n_atoms), np.uint8)
        pairs = _Pairs(enc, bits.astype(np.float32), np.arange(n), tasks, valid)
        rows = np.arange(n)
        masks = nets[0].masks_from_bits(nets[0].mask_bits(valid)) if n else nets[0].head_masks(torch.from_numpy(valid))
        items.append((pairs, rows, masks))
        with torch.no_grad():
            expect.append(pairs.values(nets[s], rows, masks) if n else None)
    with torch.no_grad():
        got = pair_q(nets[0], stack, stack.params(), items)
    for s in range(2):
        valid = torch.from_numpy(nets[0].label_valid(items[s][0].valid))
        assert got[s].shape == expect[s].shape
        assert torch.allclose(got[s][valid], expect[s][valid], rtol=1e-5, atol=1e-5)
    assert got[2].shape[0] == 0


def _run(cfgs, batched: bool):
    if batched:
        return train_runs(cfgs, progress=False)
    out = []
    for cfg in cfgs:
        t = Trainer(cfg, progress=False)
        t.train()
        out.append(t)
    return out


@pytest.mark.parametrize(
    "horizon, estimator", [("myopic", "known"), ("anticipatory", "known"), ("anticipatory", "empirical")]
)
def test_batched_seeds_follow_their_single_runs(minimal, tmp_path, horizon, estimator):
    """Two seeds trained together and each alone: after 101 updates the weights agree to float32 rounding
    (1e-5); resumed together to 600 steps (501 updates), the same actions, minibatches and replay memory
    throughout, though rounding has grown in the weights (Adam amplifies it; about 1e-3 by then). With an
    online estimate of P(τ) each seed keeps its own counts, equal to its single run's."""
    cfg = lambda seed, where, steps: small_config(
        minimal,
        tmp_path / where / str(seed),
        horizon,
        seed=seed,
        steps=steps,
        demo_tasks=20,
        hidden=32,
        estimator=estimator,
    )
    alone = _run([cfg(0, "alone", 200), cfg(3, "alone", 200)], batched=False)
    together = _run([cfg(0, "together", 200), cfg(3, "together", 200)], batched=True)
    for a, b in zip(alone, together):
        for p, q in zip(a.net.parameters(), b.net.parameters()):
            assert torch.allclose(p, q, rtol=0, atol=1e-5)
        for p, q in zip(a.target.parameters(), b.target.parameters()):
            assert torch.allclose(p, q, rtol=0, atol=1e-5)
    for a in alone:
        a.cfg.steps = 600
        a.train()
    together = train_runs([cfg(0, "together", 600), cfg(3, "together", 600)], progress=False)  # resumes both
    for a, b in zip(alone, together):
        n = len(a.memory)
        assert n == len(b.memory) == 600
        for key in ("states", "actions", "rewards", "next_states", "kinds"):
            assert np.array_equal(getattr(a.memory, key)[:n], getattr(b.memory, key)[:n]), key
        assert a.rng.bit_generator.state == b.rng.bit_generator.state  # every draw the same
        assert a.opt.state_dict()["state"][0]["step"] == b.opt.state_dict()["state"][0]["step"] == 501  # 100-600
        if estimator != "known":
            ea, eb = a.estimator.state_dict(), b.estimator.state_dict()
            assert ea.keys() == eb.keys() and all(np.array_equal(ea[k], eb[k]) for k in ea)
    # the two seeds really are apart: different weights, different worlds
    assert not torch.equal(together[0].net.encoder[0].weight, together[1].net.encoder[0].weight)
    if estimator != "known":
        assert not np.array_equal(
            together[0].estimator.state_dict()["counts"], together[1].estimator.state_dict()["counts"]
        )
    # a batched run's checkpoint holds its own weights only, and resumes alone
    a_size = (tmp_path / "alone" / "0" / "last.pt").stat().st_size
    b_size = (tmp_path / "together" / "0" / "last.pt").stat().st_size
    assert b_size < 1.2 * a_size
    again = Trainer(cfg(0, "together", 600), progress=False)
    again.resume(tmp_path / "together" / "0" / "last.pt")
    assert again.step == 600
    assert all(torch.equal(p, q) for p, q in zip(again.net.parameters(), together[0].net.parameters()))


def test_seeds_trained_together_share_their_settings(minimal, tmp_path):
    a = small_config(minimal, tmp_path / "a", seed=0, steps=10)
    with pytest.raises(DomainError, match="lr differ"):
        train_runs([a, small_config(minimal, tmp_path / "b", seed=1, steps=10, lr=0.1)], progress=False)
    with pytest.raises(DomainError, match="listed twice"):
        train_runs([a, small_config(minimal, tmp_path / "b", seed=0, steps=10)], progress=False)

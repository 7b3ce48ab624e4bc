"""The goal-object view (`task_features = "arguments+objects"`): its features, and every path that values a
(state, task) pair with the split first layer (the compiled engine's included) giving the network's own Q on the
full observation."""

import numpy as np
import pytest
import torch

from learning.encoding import Encoding
from learning.q.network import build_network
from learning.q.replay import COMPLETE, CONTINUE, Replay, mixed_batch
from learning.q.targets import BoundaryCache, SlotCache, _Pairs, td_targets
from learning.q.training import Trainer, train_runs
from learning.q.value import ValueFunction
from planning.domain.compiler import compile_domain


@pytest.fixture(scope="module")
def grid7():
    return compile_domain("domains/blockworld", "grid7x7")


def test_the_state_seen_from_the_goals_objects(grid7):
    """two-blocks(d_orange_e_green) names d, orange, e, green (slots 0-3): at the problem's start d is on
    green, e on red, orange is free and the robot is elsewhere."""
    enc = Encoding(grid7, "arguments+objects")
    assert not Encoding(grid7, "arguments").paired and enc.paired
    assert enc.obs_dim == Encoding(grid7, "arguments").obs_dim + len(enc.object_keys) and len(enc.object_keys) == 40
    task = grid7.tasks.get("two-blocks(d_orange_e_green)")
    f = enc.object_features(enc.bm.to_bits(enc.pack([grid7.init])).astype(np.float32), np.array([task.index]))
    assert {enc.object_keys[k] for k in np.flatnonzero(f[0])} == {
        (0, "at", 0, ("green",)),  # d is on green
        (2, "at", 0, ("red",)),  # e is on red
        (3, "at", 1, ("d",)),  # green holds d
    }
    one = grid7.tasks.get("one-block(d_orange)")
    assert np.array_equal(enc.object_map[one.index], enc.object_map[task.index] * (np.arange(40) < 20))


@pytest.mark.parametrize("where", [("blockworld", "grid7x7"), ("minimal", None)])
def test_every_path_gives_the_networks_q(where):
    model = compile_domain(f"domains/{where[0]}", where[1])
    enc = Encoding(model, "arguments+objects")
    assert enc.paired
    torch.manual_seed(0)
    net = build_network(enc, 32).eval()
    states = model.random_walk_states(30, 1, 10)
    packed = enc.pack(states)
    vf = ValueFunction(net, enc)
    tasks = np.resize(np.asarray(enc.support), len(states))
    obs, valid = torch.from_numpy(enc.observe(packed, tasks)), torch.from_numpy(enc.valid_for(packed, tasks))
    bits = enc.bm.to_bits(packed).astype(np.float32)
    with torch.no_grad():
        full = net(obs, valid)
        split = net.forward_pairs(
            torch.from_numpy(bits),
            torch.from_numpy(enc.task_feat),
            torch.arange(len(states)),
            torch.from_numpy(tasks),
            valid,
            objects=torch.from_numpy(enc.object_map),
        )
        pairs = _Pairs(enc, bits, np.arange(len(states)), tasks, enc.valid_for(packed, tasks))
        labels = pairs.values(net, np.arange(len(states)), net.head_masks(valid))
    assert torch.allclose(full, split, atol=1e-5)
    assert torch.allclose(
        full.max(1).values, labels.index_select(1, net.lab_of_act).masked_fill(~valid, -np.inf).max(1).values, atol=1e-5
    )
    for t in enc.support[:3]:
        one = np.full(len(states), t)
        with torch.no_grad():
            ref = net(torch.from_numpy(enc.observe(packed, one)), torch.from_numpy(enc.valid_for(packed, one)))
        assert np.allclose(vf.q_max(states, int(t)), ref.max(1).values.numpy(), atol=1e-4)
        if vf.native is not None:  # the compiled engine adds the task's goal-object columns of the true atoms
            assert np.allclose(vf.native.q_max(states, int(t)), ref.max(1).values.numpy(), atol=1e-4)
    v_ap = 0.0
    for t, p in zip(enc.support, enc.task_prob[enc.support]):
        one = np.full(len(states), t)
        with torch.no_grad():
            v_ap = (
                v_ap
                + p
                * net(torch.from_numpy(enc.observe(packed, one)), torch.from_numpy(enc.valid_for(packed, one)))
                .max(1)
                .values.double()
                .numpy()
            )
    assert np.allclose(vf.v_ap(states), v_ap, atol=1e-4)
    if vf.native is not None:
        assert np.allclose(vf.native.v_ap(states), v_ap, atol=1e-4)


def test_the_trainers_targets_are_the_double_dqn_targets_of_the_full_observation(grid7):
    """The trainer's target path (split first layer, per-label heads, slot and boundary caches) against Double DQN
    written out on the full observation: the online net's argmax over the valid actions, the target net's value
    there, on the same task within it and under P(τ') over every task at a completion."""
    enc = Encoding(grid7, "arguments+objects")
    torch.manual_seed(3)
    online, target = build_network(enc, 32).eval(), build_network(enc, 32).eval()
    for p in [*online.parameters(), *target.parameters()]:
        torch.nn.init.normal_(p, 0.0, 0.3)  # spread the values, so that argmaxes differ between the nets
    rng = np.random.default_rng(0)
    packed = enc.pack(grid7.random_walk_states(121, 5, 10))
    memory, demos = Replay(200, enc.n_words), Replay(1, enc.n_words)
    for i in range(120):
        task = int(rng.choice(enc.support))
        action = int(rng.choice(np.flatnonzero(enc.valid_for(packed[i : i + 1], [task])[0])))
        memory.add(packed[i], task, action, -0.5, packed[i + 1], COMPLETE if i % 3 == 0 else CONTINUE)

    def q(net, s, task):
        valid = enc.valid_for(s[None], [task])
        with torch.no_grad():
            out = net(torch.from_numpy(enc.observe(s[None], [task])), torch.from_numpy(valid))[0].numpy()
        return np.where(valid[0], out, -np.inf)

    def double_dqn(s, task):
        return q(target, s, task)[int(np.argmax(q(online, s, task)))]

    slots, cache, gamma = SlotCache(enc, demos.capacity + memory.capacity, online.mask_bits), BoundaryCache(), 0.97
    for _ in range(3):  # the later minibatches meet cached slots and completion states
        batch = mixed_batch(memory, demos, 48, 0.0, rng)
        y = td_targets(online, target, enc, batch, gamma, "anticipatory", cache, slots).numpy()
        expect = [
            r + gamma * double_dqn(s, int(t))
            if kind == CONTINUE
            else r + gamma * sum(enc.task_prob[u] * double_dqn(s, int(u)) for u in enc.support)
            for s, t, r, kind in zip(batch["next_states"], batch["tasks"], batch["rewards"], batch["kinds"])
        ]
        assert {CONTINUE, COMPLETE} <= set(batch["kinds"].tolist())
        assert np.allclose(y, expect, atol=1e-4)
    assert len(cache)


def test_seeds_trained_together_follow_their_single_runs(minimal, tmp_path):
    """With the goal-object view, two anticipatory seeds trained together and each alone agree after 101
    updates (float32 rounding), as with the thesis's encoding (tests/learning/test_seeds.py)."""
    from tests.learning.test_dqn import small_config

    cfg = lambda seed, where: small_config(
        minimal,
        tmp_path / where / str(seed),
        "anticipatory",
        seed=seed,
        steps=200,
        demo_tasks=20,
        hidden=32,
        task_features="arguments+objects",
    )
    alone = []
    for seed in (0, 3):
        t = Trainer(cfg(seed, "alone"), progress=False)
        t.train()
        alone.append(t)
    together = train_runs([cfg(0, "together"), cfg(3, "together")], progress=False)
    assert together[0].enc.paired
    for a, b in zip(alone, together):
        for p, q in zip(a.net.parameters(), b.net.parameters()):
            assert torch.allclose(p, q, rtol=0, atol=1e-5)


def test_a_run_with_another_encoding_keeps_its_files_apart():
    from learning.q.training import Config, bound_suffix, run_name

    cfg = Config(domain="domains/blockworld", layout="grid7x7", task_features="arguments+objects")
    assert bound_suffix(cfg) == "-features-objects"
    assert run_name("blockworld", cfg) == "blockworld-grid7x7-anticipatory-seed0-features-objects"
    assert bound_suffix(Config(task_features="arguments+goal")) == "-features-goal"
    assert bound_suffix(Config()) == "" and bound_suffix({"task_features": None}) == ""

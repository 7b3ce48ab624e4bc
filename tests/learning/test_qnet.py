"""The factored Q-network: mask-centring, exact argmax, Bellman targets on hand-made transitions, checkpoints."""

import itertools

import numpy as np
import pytest
import torch

from learning.encoding import Encoding
from learning.q.checkpoints import network_payload, save_checkpoint
from learning.q.network import build_network
from learning.q.replay import COMPLETE, CONTINUE, TERMINAL
from learning.q.targets import BoundaryCache, td_targets
from learning.q.value import load_value_function
from planning.errors import DomainError


@pytest.fixture(scope="module")
def enc(two_room):
    return Encoding(two_room)


@pytest.fixture(scope="module")
def net(enc):
    torch.manual_seed(0)
    return build_network(enc).eval()


def reference_q(net, enc, state: int, task: int) -> dict:
    """Q of every valid tuple the slow way: each head's MLP called per prefix, centred over its valid values."""
    packed = enc.pack([state])
    valid = enc.valid_for(packed, [task])[0]
    obs = torch.from_numpy(enc.observe(packed, [task]))
    tuples = {tuple(enc.labels[a]): a for a in np.flatnonzero(valid)}
    H = net.head_hidden
    with torch.no_grad():
        parts = net.from_state(net.encoder(obs))[0]
        v = float(net.value(torch.relu(parts[:H]))[0])

        def adv(d, prefix):
            z = parts[(d + 1) * H : (d + 2) * H]
            for k, c in enumerate(prefix):  # one learned table per earlier component
                z = z + net.prefix_tables[d - 1][k](torch.tensor(c))
            return net.out[d](torch.relu(z)).numpy()

        out = {}
        for t, a in tuples.items():
            q = v
            for d in range(len(t)):
                values = {u[d] for u in tuples if u[:d] == t[:d]}  # valid values of head d given the prefix
                A = adv(d, t[:d])
                q += A[t[d]] - np.mean([A[x] for x in values])
            out[a] = q
    return out


def test_mask_centring_and_exact_argmax(two_room, enc, net):
    states = two_room.random_walk_states(12, seed=3)
    rng = np.random.default_rng(0)
    for s in states:
        task = int(rng.integers(len(two_room.tasks)))
        ref = reference_q(net, enc, s, task)
        packed = enc.pack([s])
        valid = torch.from_numpy(enc.valid_for(packed, [task]))
        q = net(torch.from_numpy(enc.observe(packed, [task])), valid)[0].detach().numpy()
        # valid entries agree with the per-prefix reference, the rest are -inf
        for a, v in ref.items():
            assert q[a] == pytest.approx(v, abs=1e-4)
        assert np.isneginf(q[~valid[0].numpy()]).all()
        # the greedy action is the best of all valid tuples, enumerated by brute force
        assert int(np.argmax(q)) == max(ref, key=ref.get)
        # the valid tuples are exactly the factored labels of the applicable ground actions
        labels = {tuple(int(x) for x in enc.labels[a]) for a in ref}
        if not two_room.tasks[task].satisfied(s):
            assert labels == set(enc.factored.applicable_labels(two_room, s))


def test_centring_removes_any_per_head_offset(two_room, enc, net):
    """Advantages are centred over the mask-valid values: shifting a head's outputs leaves every Q unchanged."""
    states = two_room.random_walk_states(16, seed=5)
    packed = enc.pack(states)
    tasks = np.arange(16) % len(two_room.tasks)
    obs = torch.from_numpy(enc.observe(packed, tasks))
    valid = torch.from_numpy(enc.valid_for(packed, tasks))
    with torch.no_grad():
        before = net(obs, valid)
        for head in net.out:
            head.bias += 3.0
        after = net(obs, valid)
        for head in net.out:
            head.bias -= 3.0
        value_shift = net(obs, valid)
    assert torch.allclose(before, after, atol=1e-5)
    assert torch.allclose(before, value_shift, atol=1e-5)


def test_auto_is_the_only_valid_action_of_a_satisfied_task(minimal):
    enc = Encoding(minimal)
    s = minimal.state_from_atoms(
        ["(robot-at b)", "(hand-free)", "(at apple b)"]
        + [
            a
            for a in ["(receptacle a)", "(receptacle b)", "(receptacle c)"]
            if a.strip("()").split()[0] in {x[0] for x in minimal.atoms}
        ]
    )
    task = minimal.tasks.get("deliver(b)").index
    valid = enc.valid_for(enc.pack([s]), [task])[0]
    assert np.flatnonzero(valid).tolist() == [enc.AUTO]
    other = minimal.tasks.get("deliver(a)").index
    valid = enc.valid_for(enc.pack([s]), [other])[0]
    assert not valid[enc.AUTO] and valid.sum() == len(minimal.applicable(s))


class TableNet(torch.nn.Module):
    """A stand-in Q: value = base[task] + slope * action index (tasks read back from the one-hot)."""

    def __init__(self, enc, base, slope):
        super().__init__()
        self.enc, self.base, self.slope = enc, torch.tensor(base, dtype=torch.float32), slope

    def forward(self, obs, valid):
        feat = obs[:, self.enc.n_atoms :].numpy()
        task = torch.tensor([int(np.flatnonzero((self.enc.task_feat == f).all(1))[0]) for f in feat])
        q = self.base[task][:, None] + self.slope * torch.arange(valid.shape[1], dtype=torch.float32)[None]
        return q.masked_fill(~valid, float("-inf"))


def test_targets_on_hand_made_transitions(two_room, enc):
    T = len(two_room.tasks)
    online = TableNet(enc, np.zeros(T), slope=1.0)  # picks the highest-index valid action
    target = TableNet(enc, np.arange(T) * 10.0, slope=-1.0)  # values it differently
    s = two_room.random_walk_states(1, seed=7)[0]
    packed = enc.pack([s])
    gamma, task = 0.9, 2
    batch = {
        "next_states": np.repeat(packed, 3, axis=0),
        "tasks": np.array([task, task, task]),
        "rewards": np.array([-1.0, 80.0, 5.0], dtype=np.float32),
        "kinds": np.array([CONTINUE, COMPLETE, TERMINAL], dtype=np.int8),
    }

    def q_target(t):  # Q_target(s', t, argmax_a Q_online(s', t, a))
        valid = enc.valid_for(packed, [t])[0]
        a = int(np.flatnonzero(valid).max())
        return 10.0 * t - a

    myo = td_targets(online, target, enc, batch, gamma, "myopic").numpy()
    assert myo[0] == pytest.approx(-1.0 + gamma * q_target(task))  # timeout / within task: same task
    assert myo[1] == pytest.approx(80.0)  # myopic completion: y = r
    assert myo[2] == pytest.approx(5.0)
    ant = td_targets(online, target, enc, batch, gamma, "anticipatory").numpy()
    p = two_room.tasks.probabilities / two_room.tasks.probabilities.sum()
    v_ap = sum(p[t] * q_target(t) for t in range(T))
    assert ant[0] == pytest.approx(myo[0])
    assert ant[1] == pytest.approx(80.0 + gamma * v_ap, rel=1e-5)  # r + γ Σ P(τ') Q_target(s', τ', argmax online)
    assert ant[2] == pytest.approx(5.0)  # a declared terminal stays terminal


def test_checkpoint_round_trip_and_bad_files(two_room, three_room, enc, net, tmp_path):
    path = save_checkpoint(tmp_path / "q.pt", network_payload(net, enc))
    vf = load_value_function(path, two_room)
    states = two_room.random_walk_states(8, seed=11)
    with torch.no_grad():
        packed = enc.pack(states)
        tasks = np.zeros(8, dtype=np.int64)
        valid = torch.from_numpy(enc.valid_for(packed, tasks))
        expect = net(torch.from_numpy(enc.observe(packed, tasks)), valid).numpy()
    assert np.allclose(vf.q_values(states, 0), expect)
    assert vf.v_ap(states).shape == (8,) and np.isfinite(vf.v_ap(states)).all()
    assert np.allclose(vf.q_max(states, 0), expect.max(1))
    (tmp_path / "bad.pt").write_bytes(b"not a checkpoint")
    with pytest.raises(DomainError, match="bad.pt: not a readable checkpoint"):
        load_value_function(tmp_path / "bad.pt", two_room)
    with pytest.raises(DomainError, match="trained for restaurant/two-room"):
        load_value_function(path, three_room)
    assert not list(tmp_path.glob(".*tmp"))  # the atomic write left no temporary behind


def test_brute_force_argmax_over_all_label_tuples(minimal):
    """On the grid, enumerate the full product of head values and keep those valid in the state."""
    enc = Encoding(minimal)
    torch.manual_seed(1)
    net = build_network(enc).eval()
    for s in minimal.random_walk_states(6, seed=2):
        for task in range(len(minimal.tasks)):
            valid = enc.valid_for(enc.pack([s]), [task])[0]
            valid_tuples = {tuple(enc.labels[a]): a for a in np.flatnonzero(valid)}
            product = [t for t in itertools.product(*[range(len(v)) for v in enc.vocab]) if t in valid_tuples]
            assert len(product) == len(valid_tuples)
            ref = reference_q(net, enc, s, task)
            with torch.no_grad():
                q = net(torch.from_numpy(enc.observe(enc.pack([s]), [task])), torch.from_numpy(valid[None]))[0]
            best = max(product, key=lambda t: ref[valid_tuples[t]])
            assert int(q.argmax()) == valid_tuples[best]


def test_numpy_inference_matches_the_network(two_room, enc, net):
    from learning.q.inference import NumpyQ
    from learning.q.targets import preparedness

    states = two_room.random_walk_states(24, seed=13)
    packed = enc.pack(states)
    tasks = np.arange(24) % len(two_room.tasks)
    obs, valid = enc.observe(packed, tasks), enc.valid_for(packed, tasks)
    with torch.no_grad():
        expect = net(torch.from_numpy(obs), torch.from_numpy(valid)).numpy()
    got = NumpyQ(net)(obs, valid)
    assert np.allclose(got[valid], expect[valid], atol=1e-4) and np.isneginf(got[~valid]).all()
    from learning.q.value import ValueFunction

    assert np.allclose(ValueFunction(net, enc).v_ap(states), preparedness(net, net, enc, packed), atol=1e-4)


class CountingNet(TableNet):
    """A TableNet that counts the rows it is asked to value."""

    rows = 0

    def forward(self, obs, valid):
        self.rows += len(obs)
        return super().forward(obs, valid)


def test_boundary_cache_is_exact_and_spares_the_target_net(two_room, enc):
    T = len(two_room.tasks)
    online = TableNet(enc, np.zeros(T), slope=1.0)
    target = CountingNet(enc, np.arange(T) * 10.0, slope=-1.0)
    states = enc.pack(two_room.random_walk_states(3, seed=11))
    batch = {
        "next_states": np.concatenate([states, states[:1]]),
        "tasks": np.array([1, 2, 3, 4]),
        "rewards": np.array([-1.0, 50.0, 60.0, 50.0], dtype=np.float32),
        "kinds": np.array([CONTINUE, COMPLETE, COMPLETE, COMPLETE], dtype=np.int8),
    }
    plain = td_targets(online, target, enc, batch, 0.97, "anticipatory").numpy()
    cache = BoundaryCache()
    first = td_targets(online, target, enc, batch, 0.97, "anticipatory", cache).numpy()
    np.testing.assert_allclose(first, plain, rtol=1e-6)
    assert len(cache) == 3  # one entry per distinct completion state
    target.rows = 0
    again = td_targets(online, target, enc, batch, 0.97, "anticipatory", cache).numpy()
    np.testing.assert_allclose(again, plain, rtol=1e-6)
    assert target.rows == 1  # only the within-task row reaches the target net
    # the trainer clears the cache when the target network is synced
    target.base = target.base + 5.0
    cache.clear()
    moved = td_targets(online, target, enc, batch, 0.97, "anticipatory", cache).numpy()
    np.testing.assert_allclose(moved[1:], plain[1:] + 0.97 * 5.0, rtol=1e-5)


def _torch_q_max(net, enc, packed, tasks):
    """max over the valid actions of the plain torch forward, per (state, task) row."""
    from learning.q.network import masked_max

    obs, valid = enc.observe(packed, tasks), enc.valid_for(packed, tasks)
    with torch.no_grad():
        q = net(torch.from_numpy(obs), torch.from_numpy(valid))
        return masked_max(q, torch.from_numpy(valid))[0].double().numpy()


@pytest.mark.parametrize("weights", ["random", "trained"])
@pytest.mark.parametrize("layout", ["two_room", "three_room"])
def test_batched_q_max_and_v_ap_match_the_torch_forward(layout, weights, request):
    """The searches' fast path (BatchedQ) gives the torch forward's numbers, satisfied tasks and V_AP included."""
    from pathlib import Path

    from learning.q.inference import BatchedQ
    from learning.q.targets import _pairs
    from learning.q.value import ValueFunction

    model = request.getfixturevalue(layout)
    enc = Encoding(model)
    if weights == "random":
        torch.manual_seed(7)
        net = build_network(enc).eval()
    else:  # the large values of a trained network (two-room V reaches ~240) test float32 rounding
        ckpt = Path(f"checkpoints/rl-anticipatory-{layout.replace('_', '-')}-seed0.pt")
        if not ckpt.is_file():
            pytest.skip(f"no {ckpt}")
        net = load_value_function(ckpt, model).net
    vf = ValueFunction(net, enc)
    states = model.random_walk_states(50, seed=21)
    packed = enc.pack(states)
    # the tests of the fast path are exact: applicable actions and satisfied goals, as the encoding's
    b = vf.batched
    a = np.maximum(b.features(states) @ b.l1_base, 0)
    app = np.zeros((len(states), enc.n_actions), dtype=bool)
    rows, var = np.nonzero(a[:, b.t0 : b.g0])
    app[rows, enc.bm.op_action[var]] = True
    assert set(np.unique(a[:, b.t0 :])) <= {0.0, 1.0}
    assert np.array_equal(app, enc.applicable(packed))
    sat = enc.satisfied_all(packed)
    assert np.array_equal((a[:, b.g0 :] @ b.goal_of) > 0, sat)
    # q_max for a few tasks, among them one some of the states already satisfy (AUTO alone is valid)
    T = len(model.tasks)
    tasks = sorted({0, T // 2, T - 1, int(np.flatnonzero(sat.any(0))[0])})
    assert sat[:, tasks].any()
    for t in tasks:
        expect = _torch_q_max(net, enc, packed, np.full(len(states), t))
        got = vf.q_max(states, t)
        assert got.shape == (len(states),)
        np.testing.assert_allclose(got, expect, rtol=0, atol=1e-4)
        np.testing.assert_allclose(vf.q_max(packed, model.tasks[t]), got, rtol=0, atol=1e-5)  # packed input
    # V_AP: the support-weighted max over every (state, task) pair
    obs, valid = _pairs(enc, packed)
    with torch.no_grad():
        from learning.q.network import masked_max

        qm = masked_max(net(torch.from_numpy(obs), torch.from_numpy(valid)), torch.from_numpy(valid))[0]
    expect = qm.double().numpy().reshape(len(states), len(enc.support)) @ enc.task_prob[enc.support]
    np.testing.assert_allclose(vf.v_ap(states), expect, rtol=0, atol=1e-4)
    small = BatchedQ(net, enc, chunk=7)  # V_AP's pairs in several chunks: the same numbers
    np.testing.assert_allclose(small.v_ap(states[:9]), vf.v_ap(states[:9]), rtol=0, atol=1e-5)
    assert vf.q_max([], 0).shape == (0,) and vf.v_ap([]).shape == (0,)


# ---- the faster training path against the previous implementation ----------------------------
def reference_forward(net, obs, valid):
    """The previous FactoredQNet.forward, kept as the reference: each head evaluated at the (row,
    prefix) pairs in use, found by index bookkeeping, centred over the valid values."""
    N, H = obs.shape[0], net.head_hidden
    parts = net.from_state(net.encoder(obs))
    v = net.value(torch.relu(parts[:, :H]))[:, 0]
    rows, acts = valid.nonzero(as_tuple=True)
    q = v[rows]
    for d in range(len(net.table.sizes)):
        P = net.table.uses[d].shape[1]
        pid, val = net.table.pid[d][acts], net.table.val[d][acts]
        flat = rows * P + pid
        used = torch.zeros(N * P, dtype=torch.bool)
        used[flat] = True
        keys = used.nonzero()[:, 0]
        inv = (torch.cumsum(used, 0) - 1)[flat]
        z = parts[keys // P, (d + 1) * H : (d + 2) * H]
        if d:
            z = z + net.prefix_term(d)[keys % P]
        adv = net.out[d](torch.relu(z))
        mask = torch.zeros(adv.shape, dtype=adv.dtype).index_put((inv, val), torch.ones(()))
        mean = (adv * mask).sum(-1) / mask.sum(-1)
        q = q + adv[inv, val] - mean[inv]
    out = torch.full((N, valid.shape[1]), float("-inf"), dtype=q.dtype)
    return out.index_put((rows, acts), q)


class ReferenceNet(torch.nn.Module):
    """A FactoredQNet's weights behind the reference forward (and none of the new entry points)."""

    def __init__(self, net):
        super().__init__()
        self.net = net

    def forward(self, obs, valid):
        return reference_forward(self.net, obs, valid)


def reference_td_targets(online, target, enc, batch, gamma, horizon):
    """The previous td_targets without its cache: every continuing pair and every completion's
    pairs with the whole support through both networks, observations built in full."""
    from learning.q.network import masked_max
    from learning.q.targets import _pairs

    y = torch.as_tensor(batch["rewards"], dtype=torch.float32).clone()
    kinds, nxt = np.asarray(batch["kinds"]), batch["next_states"]
    cont = np.flatnonzero(kinds == CONTINUE)
    comp = np.flatnonzero(kinds == COMPLETE) if horizon == "anticipatory" else cont[:0]
    if not len(cont) and not len(comp):
        return y
    tasks = np.asarray(batch["tasks"])[cont]
    obs, valid = [enc.observe(nxt[cont], tasks)], [enc.valid_for(nxt[cont], tasks)]
    if len(comp):
        o, v = _pairs(enc, nxt[comp])
        obs.append(o)
        valid.append(v)
    obs, valid = torch.from_numpy(np.concatenate(obs)), torch.from_numpy(np.concatenate(valid))
    with torch.no_grad():
        _, best = masked_max(online(obs, valid), valid)
        picked = target(obs, valid).gather(1, best[:, None])[:, 0]
    n, k = len(cont), len(enc.support)
    y[torch.from_numpy(cont)] += gamma * picked[:n]
    if len(comp):
        p = torch.from_numpy(enc.task_prob[enc.support]).float()
        y[torch.from_numpy(comp)] += gamma * (picked[n:].reshape(len(comp), k) @ p)
    return y


def trained_like(enc, seed):
    """A network whose heads matter: biases and embeddings spread as after training."""
    torch.manual_seed(seed)
    net = build_network(enc)
    with torch.no_grad():
        for name, p in net.named_parameters():
            if p.dim() == 1 or "prefix" in name:
                p.normal_(0.0, 0.5)
    return net


def fixed_minibatch(model, enc, n, seed):
    """n transitions of random walks: every kind, repeated completion states, tasks that hold."""
    rng = np.random.default_rng(seed)
    states = enc.pack(model.random_walk_states(n + 1, seed=seed))
    nxt = states[1:].copy()
    nxt[n // 2 : n // 2 + 6] = nxt[n // 2]  # one completion state six times
    kinds = rng.choice([CONTINUE, COMPLETE, TERMINAL], size=n, p=[0.7, 0.2, 0.1]).astype(np.int8)
    kinds[n // 2 : n // 2 + 6] = COMPLETE
    tasks = rng.integers(len(model.tasks), size=n)
    holds = enc.satisfied_all(states[:-1])  # some rows' task already holds: AUTO
    for i in np.flatnonzero(holds.any(1))[:8]:
        tasks[i] = int(np.flatnonzero(holds[i])[0])
    valid = enc.valid_for(states[:-1], tasks)
    actions = np.array([rng.choice(np.flatnonzero(v)) for v in valid])
    return {
        "states": states[:-1],
        "next_states": nxt,
        "tasks": tasks,
        "actions": actions,
        "rewards": rng.normal(0.0, 3.0, size=n).astype(np.float32),
        "kinds": kinds,
    }


def test_dense_heads_give_the_reference_q_and_gradients(restaurant):
    """The live-prefix, label-level forward equals the previous one: Q, -inf pattern and every gradient."""
    enc = Encoding(restaurant)
    net = trained_like(enc, 0)
    b = fixed_minibatch(restaurant, enc, 160, seed=1)
    obs, valid = (
        torch.from_numpy(enc.observe(b["states"], b["tasks"])),
        torch.from_numpy(enc.valid_for(b["states"], b["tasks"])),
    )
    acts = torch.from_numpy(b["actions"])
    grads = []
    for q in (
        lambda: reference_forward(net, obs, valid),
        lambda: net(obs, valid),
        lambda: net.q_taken(obs, valid, acts)[:, None],
    ):
        net.zero_grad(set_to_none=True)
        out = q()
        taken = out.gather(1, acts[:, None]) if out.shape[1] > 1 else out
        (taken**2).mean().backward()
        grads.append({k: p.grad if p.grad is not None else torch.zeros_like(p) for k, p in net.named_parameters()})
        if out.shape[1] > 1:
            grads[-1]["q"] = out.detach()
    ref, new, taken = grads
    assert torch.equal(torch.isinf(ref["q"]), torch.isinf(new["q"])) and torch.isinf(ref["q"]).sum() > 0
    fin = torch.isfinite(ref["q"])
    assert ref["q"][fin].abs().max() > 1.0  # the heads are not trivial
    torch.testing.assert_close(new["q"][fin], ref["q"][fin], rtol=1e-5, atol=1e-5)
    for g in (new, taken):
        for k, _ in net.named_parameters():
            torch.testing.assert_close(g[k], ref[k], rtol=1e-4, atol=1e-6, msg=k)
    assert ref["out.0.weight"].abs().sum() > 0 and ref["prefix_tables.1.1.weight"].abs().sum() > 0


def test_split_first_layer_gives_the_same_q(two_room, enc):
    net = trained_like(enc, 1)
    states = enc.pack(two_room.random_walk_states(12, seed=4))
    tasks = np.tile(enc.support, 12)
    rows = np.repeat(np.arange(12), len(enc.support))
    valid = torch.from_numpy(enc.valid_for(states[rows], tasks))
    with torch.no_grad():
        plain = net(torch.from_numpy(enc.observe(states[rows], tasks)), valid)
        split = net.forward_pairs(
            torch.from_numpy(enc.bm.to_bits(states).astype(np.float32)),
            torch.from_numpy(enc.task_feat),
            torch.from_numpy(rows),
            torch.from_numpy(tasks),
            valid,
        )
    assert torch.equal(torch.isinf(plain), torch.isinf(split))
    torch.testing.assert_close(split[valid], plain[valid], rtol=1e-5, atol=1e-5)


@pytest.mark.parametrize("horizon", ["myopic", "anticipatory"])
def test_faster_update_gives_the_reference_targets_and_gradients(two_room, enc, horizon):
    """On a fixed minibatch: the same Double-DQN targets as the previous code (with and without the
    boundary cache, from a cold and a warm cache) and the same gradient of the Huber loss."""
    import torch.nn.functional as F

    online, target = trained_like(enc, 2), trained_like(enc, 3)
    b = fixed_minibatch(two_room, enc, 128, seed=5)
    assert (b["kinds"] == COMPLETE).sum() >= 6 and len(np.unique(b["next_states"][b["kinds"] == COMPLETE], axis=0)) < (
        b["kinds"] == COMPLETE
    ).sum()
    ref = reference_td_targets(ReferenceNet(online), ReferenceNet(target), enc, b, 0.97, horizon)
    cache = BoundaryCache()
    for y in (
        td_targets(online, target, enc, b, 0.97, horizon),
        td_targets(online, target, enc, b, 0.97, horizon, cache),
        td_targets(online, target, enc, b, 0.97, horizon, cache),
    ):  # the cache's values
        torch.testing.assert_close(y, ref, rtol=1e-5, atol=1e-4)
    assert len(cache) == (
        0 if horizon == "myopic" else len(np.unique(b["next_states"][b["kinds"] == COMPLETE], axis=0))
    )
    assert not torch.allclose(ref, torch.as_tensor(b["rewards"]))  # the bootstrap matters
    obs, valid = (
        torch.from_numpy(enc.observe(b["states"], b["tasks"])),
        torch.from_numpy(enc.valid_for(b["states"], b["tasks"])),
    )
    acts = torch.from_numpy(b["actions"])
    grads = []
    for q, y in (
        (lambda: reference_forward(online, obs, valid).gather(1, acts[:, None])[:, 0], ref),
        (lambda: online.q_taken(obs, valid, acts), td_targets(online, target, enc, b, 0.97, horizon, cache)),
    ):
        online.zero_grad(set_to_none=True)
        F.smooth_l1_loss(q(), y).backward()
        grads.append({k: p.grad if p.grad is not None else torch.zeros_like(p) for k, p in online.named_parameters()})
    for k in grads[0]:
        torch.testing.assert_close(grads[1][k], grads[0][k], rtol=1e-4, atol=1e-6, msg=k)


from pathlib import Path  # noqa: E402


@pytest.mark.parametrize("path", sorted(str(p) for p in Path("checkpoints").glob("rl-*.pt")))
def test_committed_checkpoints_act_as_before(path):
    """Every committed Q-network checkpoint loads and its greedy actions on 50 states are the reference forward's,
    through the training forward and through load_value_function. Float32 rounding (which depends on the
    kernels' summation order) is relative to a row's largest value, so the values agree to 1e-4 of it and the
    actions wherever their gap exceeds that (a diverged network's values reach 1e10)."""
    from planning.domain.compiler import compile_domain

    layout = "three-room" if "three-room" in path else "two-room"
    model = compile_domain("domains/restaurant", layout)
    vf = load_value_function(path, model)
    states = model.random_walk_states(50, seed=17)
    packed = vf.enc.pack(states)
    tasks = np.random.default_rng(0).integers(len(model.tasks), size=50)
    obs, valid = torch.from_numpy(vf.enc.observe(packed, tasks)), torch.from_numpy(vf.enc.valid_for(packed, tasks))
    with torch.no_grad():
        ref = reference_forward(vf.net, obs, valid)
        new = vf.net(obs, valid)
    tol = 1e-4 * ref.masked_fill(~valid, 0).abs().amax(1, keepdim=True).clamp(min=1.0)
    assert ((new - ref).abs() <= tol)[valid].all()
    top2 = ref.masked_fill(~valid, -float("inf")).topk(2, 1).values
    clear = (top2[:, 0] - top2[:, 1] > 2 * tol[:, 0]).numpy()
    assert clear.sum() >= 45
    assert torch.equal(new.argmax(1)[clear], ref.argmax(1)[clear])
    greedy = np.array([int(vf.greedy([s], int(t))[0]) for s, t in zip(states, tasks)])
    assert np.array_equal(greedy[clear], ref.argmax(1).numpy()[clear])


def test_live_greedy_acts_as_the_forward_and_follows_the_weights(restaurant):
    """The trainer's numpy acting: the forward's argmax, also after the weights change in place."""
    from learning.q.inference import LiveGreedy
    from learning.q.network import masked_max

    enc = Encoding(restaurant)
    net = trained_like(enc, 4)
    greedy = LiveGreedy(net)
    states = restaurant.random_walk_states(120, seed=8)
    tasks = np.random.default_rng(1).integers(len(restaurant.tasks), size=120)
    obs = enc.observe(enc.pack(states), tasks)
    valid = np.zeros((120, enc.n_actions), dtype=bool)
    for i, s in enumerate(states):
        valid[i, restaurant.applicable(s)] = True
    for _ in range(2):
        with torch.no_grad():
            expect = masked_max(net(torch.from_numpy(obs), torch.from_numpy(valid)), torch.from_numpy(valid))[1]
        assert [greedy(o, v) for o, v in zip(obs, valid)] == expect.tolist()
        with torch.no_grad():  # an optimizer step changes the weights in place
            for p in net.parameters():
                p.add_(0.2 * torch.randn_like(p))


def test_slot_cache_gives_the_same_targets_and_observations(two_room, enc):
    """Per-slot encodings and target values: the same targets and (s, τ) rows as computing them
    afresh, after slots are rewritten and after the target network changes (a sync)."""
    from learning.q.replay import Replay, mixed_batch
    from learning.q.targets import SlotCache

    online, target = trained_like(enc, 6), trained_like(enc, 7)
    agent, demos = Replay(40, enc.n_words), Replay(30, enc.n_words)
    fill = lambda memory, n, seed: [
        memory.add(b["states"][i], b["tasks"][i], b["actions"][i], b["rewards"][i], b["next_states"][i], b["kinds"][i])
        for b in [fixed_minibatch(two_room, enc, n, seed)]
        for i in range(n)
    ]
    fill(demos, 30, 10)
    fill(agent, 40, 11)
    slots, rng = SlotCache(enc, demos.capacity + agent.capacity, online.mask_bits), np.random.default_rng(0)
    for round_ in range(4):
        if round_ == 2:
            fill(agent, 25, 12)  # rewritten slots: new transitions there
        if round_ == 3:
            with torch.no_grad():
                for p in target.parameters():
                    p.add_(0.3)
            slots.sync()
        for _ in range(3):
            b = mixed_batch(agent, demos, 64, 0.25, rng)
            expect = td_targets(online, target, enc, b, 0.97, "anticipatory")
            torch.testing.assert_close(
                td_targets(online, target, enc, b, 0.97, "anticipatory", None, slots), expect, rtol=1e-5, atol=1e-4
            )
            again = td_targets(online, target, enc, b, 0.97, "anticipatory", None, slots)  # all known: no target rows
            torch.testing.assert_close(again, expect, rtol=1e-5, atol=1e-4)
            obs, valid, mask_bits = slots.observe(b)
            assert np.array_equal(obs, enc.observe(b["states"], b["tasks"]))
            assert np.array_equal(valid, enc.valid_for(b["states"], b["tasks"]))
            # the kept head masks are the network's, of this validity
            for kept, fresh in zip(online.masks_from_bits(mask_bits), online.head_masks(torch.from_numpy(valid))):
                assert torch.equal(kept, fresh)
    assert slots.known(b["slots"][b["kinds"] == CONTINUE]).all()


def test_empty_batches_and_no_row_to_value(two_room, enc):
    """No rows at all, and (with both caches warm) no row for the target network: the same targets."""
    from learning.q.replay import Replay, mixed_batch
    from learning.q.targets import SlotCache

    net = trained_like(enc, 9)
    valid = torch.from_numpy(enc.valid_for(enc.pack(two_room.random_walk_states(1, seed=2)), [0]))[:0]
    assert net(torch.zeros(0, enc.obs_dim), valid).shape == (0, enc.n_actions)
    memory = Replay(20, enc.n_words)
    b = fixed_minibatch(two_room, enc, 20, seed=13)
    for i in range(20):
        memory.add(b["states"][i], b["tasks"][i], b["actions"][i], b["rewards"][i], b["next_states"][i], b["kinds"][i])
    batch = mixed_batch(memory, Replay(1, enc.n_words), 20, 0.0, np.random.default_rng(3))
    slots, cache = SlotCache(enc, 21), BoundaryCache()
    first = td_targets(net, net, enc, batch, 0.9, "anticipatory", cache, slots)
    torch.testing.assert_close(td_targets(net, net, enc, batch, 0.9, "anticipatory", cache, slots), first)


def test_compact_checkpoint_acts_as_the_full_one(three_room, tmp_path):
    """learning.export's float16 checkpoint: about half the bytes, loaded safely, the same greedy actions."""
    from learning.export import compact
    from learning.q.checkpoints import read_checkpoint, save_checkpoint

    payload = read_checkpoint("checkpoints/rl-anticipatory-three-room-seed0.pt")  # float32 once loaded
    payload.pop("precision", None)
    g = torch.Generator().manual_seed(0)  # weights float16 cannot hold exactly, as a trainer's
    payload["net"] = {
        k: v * (1 + 1e-3 * torch.randn(v.shape, generator=g)) if v.is_floating_point() else v
        for k, v in payload["net"].items()
    }
    full = save_checkpoint(tmp_path / "full.pt", payload)
    small = save_checkpoint(tmp_path / "small.pt", compact(read_checkpoint(full)))
    assert small.stat().st_size < 0.55 * full.stat().st_size
    payload = read_checkpoint(small)
    assert payload["precision"] == "float16" and all(v.dtype != torch.float16 for v in payload["net"].values())
    a, b = load_value_function(full, three_room), load_value_function(small, three_room)
    assert not torch.equal(a.net.encoder[0].weight, b.net.encoder[0].weight)  # float16 rounding did happen
    states = three_room.random_walk_states(300, seed=5)
    tasks = np.random.default_rng(1).integers(len(three_room.tasks), size=len(states))
    greedy = lambda vf: [int(vf.greedy([s], int(t))[0]) for s, t in zip(states, tasks)]
    assert greedy(a) == greedy(b)
    np.testing.assert_allclose(b.v_ap(states[:20]), a.v_ap(states[:20]), rtol=2e-3)


@pytest.mark.parametrize(
    "path, precision",
    [
        ("checkpoints/rl-anticipatory-three-room-seed0.pt", "float16"),
        ("checkpoints/rl-myopic-three-room-seed4.pt", "float32"),
    ],
)
def test_export_keeps_float32_where_float16_would_change_the_greedy_actions(path, precision):
    """A healthy network's float16 weights swap at most near-tied actions; the diverged three-room myopic
    seed-4 network's values (about 1e10) move by more than their gaps, so its export stays float32."""
    from learning.export import TIE, faithful_compact
    from learning.q.checkpoints import read_checkpoint

    payload = read_checkpoint(path)
    g = torch.Generator().manual_seed(0)  # weights float16 cannot hold exactly, as a trainer's
    payload["net"] = {
        k: v * (1 + 1e-3 * torch.randn(v.shape, generator=g)) if v.is_floating_point() else v
        for k, v in payload["net"].items()
    }
    small, loss = faithful_compact(payload)
    assert small["precision"] == precision
    assert (loss < TIE) == (precision == "float16")
    assert all(v.dtype == getattr(torch, precision) for v in small["net"].values() if v.is_floating_point())


def test_key_figures_of_a_run():
    """Milestones take the last row at or before them; the wall time sums each window's steps over its rate."""
    from learning.export import key_figures

    logs = [
        {
            "step": s,
            "success_rate": s / 600_000,
            "selected_q": 10.0 + s / 1e4,
            "td_target": 9.0,
            "action_share": {"refill-water": 0.01},
            "steps_per_s": 100.0,
        }
        for s in range(25_000, 275_000, 25_000)
    ]
    logs[3]["selected_q"] = -900.0
    evals = [
        {"step": 50_000, "success_rate": 0.5, "task_return": 1.0, "demo_q_bias": 0.25},
        {"step": 200_000, "success_rate": 0.9, "task_return": 2.0},
    ]
    f = key_figures(logs, evals, "refill-water")
    assert set(f["at"]) == {"50000", "100000", "250000"}
    assert f["at"]["250000"]["step"] == 250_000 and f["at"]["100000"]["greedy"]["demo_q_bias"] == 0.25
    assert f["best_greedy"]["step"] == 200_000
    assert f["greedy_checks"] == [  # every greedy check, in order: the learning curve
        {"step": 50_000, "success_rate": 0.5, "task_return": 1.0, "demo_q_bias": 0.25},
        {"step": 200_000, "success_rate": 0.9, "task_return": 2.0},
    ]
    assert f["peak_selected_q"] == {"step": 100_000, "selected_q": -900.0}
    assert f["peak_refill_share"] == {"step": 250_000, "share": 0.01}  # ties: the latest window
    # the cumulative share since step 0: windows of 25k steps at 0.01, then one at 0.04
    logs[-1]["action_share"] = {"refill-water": 0.04}
    f = key_figures(logs, evals, "refill-water")
    assert f["at"]["100000"]["refill_share_cumulative"] == 0.01
    assert f["at"]["250000"]["refill_share_cumulative"] == round((9 * 0.01 + 0.04) / 10, 5)
    assert f["peak_refill_share_cumulative"] == {"step": 250_000, "share": 0.013}
    assert f["train_hours"] == round(250_000 / 100 / 3600, 3)
    # the curve Figure A.1 is drawn from: a row every 5,000 steps and the last one
    logs = [{**logs[0], "step": s, "selected_q": 1 / 3} for s in range(1_000, 12_001, 1_000)]
    f = key_figures(logs, evals, "refill-water")
    assert [r["step"] for r in f["curve"]] == [5_000, 10_000, 12_000]
    assert f["curve"][0] == {
        "step": 5_000,
        "success_rate": 0.041667,
        "selected_q": 0.33333,
        "td_target": 9.0,
        "refill_share_cumulative": 0.01,
    }
    # a domain that declares no preparation action: no share, the rest alike
    f = key_figures(logs, evals)
    assert f["refill_action"] is None and f["peak_refill_share"] is None
    assert f["curve"][0]["refill_share_cumulative"] is None and f["curve"][0]["td_target"] == 9.0

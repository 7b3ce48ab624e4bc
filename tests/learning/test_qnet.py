"""The factored Q-network: mask-centring, exact argmax, Bellman targets on hand-made transitions, checkpoints."""
import itertools

import numpy as np
import pytest
import torch

from learning.encoding import Encoding
from learning.qnet import (COMPLETE, CONTINUE, TERMINAL, BoundaryCache, build_network, load_value_function,
                           network_payload,
                           save_checkpoint, td_targets)
from planning.errors import DomainError
from tests.conftest import random_walk_states


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
            z = parts[(d + 1) * H:(d + 2) * H]
            for k, c in enumerate(prefix):      # one learned table per earlier component
                z = z + net.prefix_tables[d - 1][k](torch.tensor(c))
            return net.out[d](torch.relu(z)).numpy()

        out = {}
        for t, a in tuples.items():
            q = v
            for d in range(len(t)):
                values = {u[d] for u in tuples if u[:d] == t[:d]}   # valid values of head d given the prefix
                A = adv(d, t[:d])
                q += A[t[d]] - np.mean([A[x] for x in values])
            out[a] = q
    return out


def test_mask_centring_and_exact_argmax(two_room, enc, net):
    states = random_walk_states(two_room, 12, seed=3)
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
    states = random_walk_states(two_room, 16, seed=5)
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
    s = minimal.state_from_atoms(["(robot-at b)", "(hand-free)", "(at apple b)"] +
                                 [a for a in ["(receptacle a)", "(receptacle b)", "(receptacle c)"]
                                  if a.strip("()").split()[0] in {x[0] for x in minimal.atoms}])
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
        feat = obs[:, self.enc.n_atoms:].numpy()
        task = torch.tensor([int(np.flatnonzero((self.enc.task_feat == f).all(1))[0]) for f in feat])
        q = self.base[task][:, None] + self.slope * torch.arange(valid.shape[1], dtype=torch.float32)[None]
        return q.masked_fill(~valid, float("-inf"))


def test_targets_on_hand_made_transitions(two_room, enc):
    T = len(two_room.tasks)
    online = TableNet(enc, np.zeros(T), slope=1.0)          # picks the highest-index valid action
    target = TableNet(enc, np.arange(T) * 10.0, slope=-1.0)  # values it differently
    s = random_walk_states(two_room, 1, seed=7)[0]
    packed = enc.pack([s])
    gamma, task = 0.9, 2
    batch = {"next_states": np.repeat(packed, 3, axis=0), "tasks": np.array([task, task, task]),
             "rewards": np.array([-1.0, 80.0, 5.0], dtype=np.float32),
             "kinds": np.array([CONTINUE, COMPLETE, TERMINAL], dtype=np.int8)}

    def q_target(t):   # Q_target(s', t, argmax_a Q_online(s', t, a))
        valid = enc.valid_for(packed, [t])[0]
        a = int(np.flatnonzero(valid).max())
        return 10.0 * t - a

    myo = td_targets(online, target, enc, batch, gamma, "myopic").numpy()
    assert myo[0] == pytest.approx(-1.0 + gamma * q_target(task))     # timeout / within task: same task
    assert myo[1] == pytest.approx(80.0)                               # myopic completion: y = r
    assert myo[2] == pytest.approx(5.0)
    ant = td_targets(online, target, enc, batch, gamma, "anticipatory").numpy()
    p = two_room.tasks.probabilities / two_room.tasks.probabilities.sum()
    v_ap = sum(p[t] * q_target(t) for t in range(T))
    assert ant[0] == pytest.approx(myo[0])
    assert ant[1] == pytest.approx(80.0 + gamma * v_ap, rel=1e-5)    # r + γ Σ P(τ') Q_target(s', τ', argmax online)
    assert ant[2] == pytest.approx(5.0)                                # a declared terminal stays terminal


def test_checkpoint_round_trip_and_bad_files(two_room, three_room, enc, net, tmp_path):
    path = save_checkpoint(tmp_path / "q.pt", network_payload(net, enc))
    vf = load_value_function(path, two_room)
    states = random_walk_states(two_room, 8, seed=11)
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
    assert not list(tmp_path.glob(".*tmp"))      # the atomic write left no temporary behind


def test_brute_force_argmax_over_all_label_tuples(minimal):
    """On the grid, enumerate the full product of head values and keep those valid in the state."""
    enc = Encoding(minimal)
    torch.manual_seed(1)
    net = build_network(enc).eval()
    for s in random_walk_states(minimal, 6, seed=2):
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
    from learning.qnet import NumpyQ, preparedness

    states = random_walk_states(two_room, 24, seed=13)
    packed = enc.pack(states)
    tasks = np.arange(24) % len(two_room.tasks)
    obs, valid = enc.observe(packed, tasks), enc.valid_for(packed, tasks)
    with torch.no_grad():
        expect = net(torch.from_numpy(obs), torch.from_numpy(valid)).numpy()
    got = NumpyQ(net)(obs, valid)
    assert np.allclose(got[valid], expect[valid], atol=1e-4) and np.isneginf(got[~valid]).all()
    from learning.qnet import ValueFunction
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
    states = enc.pack(random_walk_states(two_room, 3, seed=11))
    batch = {"next_states": np.concatenate([states, states[:1]]), "tasks": np.array([1, 2, 3, 4]),
             "rewards": np.array([-1.0, 50.0, 60.0, 50.0], dtype=np.float32),
             "kinds": np.array([CONTINUE, COMPLETE, COMPLETE, COMPLETE], dtype=np.int8)}
    plain = td_targets(online, target, enc, batch, 0.97, "anticipatory").numpy()
    cache = BoundaryCache()
    first = td_targets(online, target, enc, batch, 0.97, "anticipatory", cache).numpy()
    np.testing.assert_allclose(first, plain, rtol=1e-6)
    assert len(cache) == 3                                   # one entry per distinct completion state
    target.rows = 0
    again = td_targets(online, target, enc, batch, 0.97, "anticipatory", cache).numpy()
    np.testing.assert_allclose(again, plain, rtol=1e-6)
    assert target.rows == 1                                  # only the within-task row reaches the target net
    # the trainer clears the cache when the target network is synced
    target.base = target.base + 5.0
    cache.clear()
    moved = td_targets(online, target, enc, batch, 0.97, "anticipatory", cache).numpy()
    np.testing.assert_allclose(moved[1:], plain[1:] + 0.97 * 5.0, rtol=1e-5)

"""Several training runs in one process: independent seeds whose network arithmetic is batched.

`learning.dqn --seed 0,4,8,16` trains four runs at once. Each seed is a whole
`learning.q.training.Trainer`: its own world, task stream, replay and demo memories,
exploration generator, target network, caches, run folder and checkpoints. They step in
lockstep (`training.train_loop`) and share only the arithmetic of their updates:

- the seeds' online parameters are views into the rows of one (S, P) tensor, their target
  parameters into another (`Stack`); each seed's own modules keep working on their row
  (acting, evaluation, checkpoints, target syncs);
- an update samples each seed's minibatch from its own memories with its own generator and
  plans each seed's Double-DQN targets (`targets.TargetPlan`, numpy); then the online argmax,
  the target values and the minibatch's forward and backward pass of all seeds are one batched
  matrix product per layer (`torch.bmm`), each seed's rows padded to the largest seed's;
- the clipped Adam step is one fused step over the (S, P) buffer, each seed's gradient norm
  clipped on its own (`StackedAdam`).

Per element every seed computes what its single run computes; only the order of the sums
inside a batched matrix product may differ, so values agree to float32 rounding and a seed
trained here takes the same actions, draws the same minibatches and fills the same replay
memory as alone until a near-tie of Q flips a greedy choice (`tests/learning/test_seeds.py`).

What batching saves is per-operation overhead. On a CPU core an update of this network is
bound by arithmetic and memory traffic instead: its matrix products run near the core's peak
and its other operations scale with the rows they touch, so S seeds cost about S single
updates (`learning.q.bench --seeds 4` measures the aggregate rate against one seed in the same
process; committed: results/dqn-bench-seeds-two-room.json). Batching pays where per-kernel
overhead dominates, as on a GPU.
"""

from __future__ import annotations

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from planning.errors import DomainError

from .inference import LiveGreedy
from .network import FactoredQNet, object_pairs
from .replay import mixed_batch
from .targets import TargetPlan


class Stack:
    """S networks of one architecture whose parameters are views into the rows of one (S, P) tensor:
    `params()` gives each parameter stacked over the seeds (S, *shape), differentiable into `flat`."""

    def __init__(self, nets: list, grad: bool):
        self.nets = nets
        named = list(nets[0].named_parameters())
        self.names = [n for n, _ in named]
        self.shapes = [p.shape for _, p in named]
        self.sizes = [p.numel() for _, p in named]
        with torch.no_grad():
            flat = torch.stack([torch.cat([p.detach().reshape(-1) for p in net.parameters()]) for net in nets])
        self.flat = nn.Parameter(flat, requires_grad=grad)
        if grad:
            self.flat.grad = torch.zeros_like(flat)
        for s, net in enumerate(nets):
            for p, view in zip(net.parameters(), self.flat.data[s].split(self.sizes)):
                p.data = view.view(p.shape)  # seed s's module now lives in row s
                p.grad = None
        name_of = {id(m): name for name, m in nets[0].named_modules()}
        self.prefix_names = [name_of[id(t)] + ".weight" for t in getattr(nets[0], "prefix_mods", ())]
        self.out_names = [name_of[id(o)] for o in getattr(nets[0], "out_mods", ())]  # the live heads' layers

    def params(self) -> dict:
        """name -> (S, *shape) view of `flat` (gradients flow into flat.grad)."""
        S, out, lo = len(self.nets), {}, 0
        for name, shape, n in zip(self.names, self.shapes, self.sizes):
            out[name] = self.flat[:, lo : lo + n].view(S, *shape)
            lo += n
        return out


class StackedAdam:
    """Adam (torch's fused kernel) over a `Stack`'s (S, P) buffer with each seed's gradient clipped to
    max_norm by its own global norm: per seed the rule and arithmetic of `optim.FlatAdam`."""

    def __init__(self, stack: Stack, lr: float):
        self.stack = stack
        self.opt = torch.optim.Adam([stack.flat], lr=lr, fused=True)
        self.pending: dict = {}

    def zero_grad(self) -> None:
        self.stack.flat.grad.zero_()

    def step(self, max_norm: float) -> None:
        g = self.stack.flat.grad
        g.mul_((max_norm / (torch.linalg.vector_norm(g, dim=1, keepdim=True) + 1e-6)).clamp_(max=1.0))
        self.opt.step()

    def of_seed(self, s: int) -> "SeedAdam":
        """What seed s's trainer keeps as its optimizer: its row's state, in FlatAdam's format."""
        return SeedAdam(self, s)

    def load_pending(self) -> None:
        """Install the per-seed states given to `SeedAdam.load_state_dict` (after every seed resumed)."""
        if not self.pending:
            return
        if len(self.pending) != len(self.stack.nets):
            raise DomainError("--seed", "some seeds of the batch resumed an optimizer state and others did not")
        steps = {float(sd["state"][0]["step"]) if sd["state"] else 0.0 for sd in self.pending.values()}
        if len(steps) > 1:
            raise DomainError("--seed", f"the seeds' optimizers took different numbers of steps ({sorted(steps)})")
        group = {**self.pending[0]["param_groups"][0], "params": [0]}
        state = {}
        if steps != {0.0}:
            rows = [self.pending[s]["state"] for s in range(len(self.stack.nets))]
            state = {
                0: {
                    "step": rows[0][0]["step"].clone(),
                    **{
                        key: torch.stack([torch.cat([r[i][key].reshape(-1) for i in range(len(r))]) for r in rows])
                        for key in ("exp_avg", "exp_avg_sq")
                    },
                }
            }
        self.opt.load_state_dict({"state": state, "param_groups": [group]})
        self.pending.clear()


class SeedAdam:
    """One seed's view of a `StackedAdam`: `state_dict` / `load_state_dict` in `optim.FlatAdam`'s
    per-parameter format, so a run saved alone resumes batched and the other way round."""

    def __init__(self, stacked: StackedAdam, s: int):
        self.stacked, self.s = stacked, s

    def state_dict(self) -> dict:
        st = self.stacked
        sd = st.opt.state_dict()
        group = {**sd["param_groups"][0], "params": list(range(len(st.stack.sizes)))}
        flat = sd["state"].get(0)
        state = {}
        if flat is not None:
            m, v = (flat[key][self.s].split(st.stack.sizes) for key in ("exp_avg", "exp_avg_sq"))
            state = {
                i: {
                    "step": flat["step"].clone(),
                    "exp_avg": a.reshape(shape).clone(),
                    "exp_avg_sq": b.reshape(shape).clone(),
                }
                for i, (a, b, shape) in enumerate(zip(m, v, st.stack.shapes))
            }
        return {"state": state, "param_groups": [group]}

    def load_state_dict(self, sd: dict) -> None:
        self.stacked.pending[self.s] = sd


# ---- the batched network evaluations ------------------------------------------------------------
def _linear(x: torch.Tensor, w: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """F.linear per seed: x (S, N, in), w (S, out, in), b (S, out)."""
    return torch.baddbmm(b[:, None], x, w.transpose(1, 2))


def q_labels(net: FactoredQNet, stack: Stack, P: dict, pre: torch.Tensor, masks: tuple) -> torch.Tensor:
    """(S, N, labels) `FactoredQNet.q_labels` of every seed at once: pre (S, N, hidden) first-layer
    pre-activations, masks ((S, I, N, V), (S, I, N, 1)). The instances evaluated are those some row of
    some seed uses; at the others a seed's centred advantages are 0 exactly, as in `q_labels`."""
    H, w = net.head_hidden, net.state_width
    S, N = pre.shape[:2]
    h = _linear(torch.relu(pre), P["encoder.2.weight"], P["encoder.2.bias"]).relu_()
    parts = _linear(h, P["from_state.weight"][:, :w], P["from_state.bias"][:, :w])
    v = _linear(torch.relu(parts[..., :H]), P["value.weight"], P["value.bias"])  # (S, N, 1)
    L = net.lab_of_slot.shape[1]
    m, count = masks
    act = (count[..., 0] >= 2).any(2).any(0).nonzero()[:, 0]  # instances in use by some seed's row
    if not len(act):
        return v.expand(-1, -1, L)
    if len(act) < net.n_inst:
        m, count = m.index_select(1, act), count.index_select(1, act)
    z = parts[..., H:].reshape(S, N, w // H - 1, H).transpose(1, 2).index_select(1, net.inst_head[act])  # (S,K,N,H)
    if net.prefix_mods:
        tabs = torch.cat([P[name] for name in stack.prefix_names], 1)  # (S, R, H)
        z = z + torch.matmul(net.bag_of.index_select(0, act), tabs)[:, :, None]  # + the prefix parts
    zero = pre.new_zeros(S, 1, H)
    w_out = torch.cat([P[name + ".weight"] for name in stack.out_names] + [zero], 1)  # (S, Vt+1, H)
    b_out = torch.cat([P[name + ".bias"] for name in stack.out_names] + [zero[:, :, 0]], 1)
    K = len(act)
    adv = torch.baddbmm(b_out[:, None], z.relu().reshape(S, K * N, H), w_out.transpose(1, 2)).view(S, K, N, -1)
    adv = adv.gather(3, net.out_col.index_select(0, act)[None].expand(S, -1, N, -1))  # (S, K, N, V)
    c = adv - (adv * m).sum(-1, keepdim=True) / count  # centred over the valid values
    slots = net.lab_of_slot.view(net.n_inst, net.v_max, L).index_select(0, act).reshape(-1, L)
    return torch.matmul(c.permute(0, 2, 1, 3).reshape(S, N, -1), slots) + v


def _pad(arrays: list, rows: int, fill=0) -> np.ndarray:
    """Stack per-seed arrays of different lengths along a new first axis, padded to `rows` with fill."""
    out = np.full((len(arrays), rows, *arrays[0].shape[1:]), fill, dtype=arrays[0].dtype)
    for s, a in enumerate(arrays):
        out[s, : len(a)] = a
    return out


def _stack_masks(masks: list, rows: int) -> tuple:
    """Per-seed head masks ((I, n_s, V), (I, n_s, 1)) as ((S, I, rows, V), (S, I, rows, 1)), padded
    with no valid value (count 1)."""
    m0 = masks[0][0]
    m = m0.new_zeros(len(masks), m0.shape[0], rows, m0.shape[2])
    count = m0.new_ones(len(masks), m0.shape[0], rows, 1)
    for s, (ms, cs) in enumerate(masks):
        m[s, :, : ms.shape[1]] = ms
        count[s, :, : cs.shape[1]] = cs
    return m, count


def pair_q(net: FactoredQNet, stack: Stack, P: dict, items: list) -> list:
    """Each seed's Q at rows of its `targets._Pairs` (items: (pairs, rows, masks) per seed; rows may be
    empty): `_Pairs.values` of S networks in one batched evaluation; a list of (rows, labels) tensors."""
    S = len(items)
    inputs = [pairs._inputs(rows, torch.device("cpu")) for pairs, rows, _ in items]
    n = [len(rows) for _, rows, _ in items]
    N, Ns = max(1, max(n)), max(1, max(len(x[0]) for x in inputs))
    bits = torch.from_numpy(_pad([x[0].numpy() for x in inputs], Ns))
    state_of = torch.from_numpy(_pad([x[2].numpy() for x in inputs], N))
    task_of = torch.from_numpy(_pad([x[3].numpy() for x in inputs], N))
    feat, objects = inputs[0][1], inputs[0][4]
    w, b, k = P["encoder.0.weight"], P["encoder.0.bias"], bits.shape[2]
    kt = k + feat.shape[1]
    a = torch.bmm(bits, w[:, :, :k].transpose(1, 2))  # the state part, once per distinct state
    t = _linear(feat.expand(S, -1, -1), w[:, :, k:kt], b)  # the task part, once per task
    seeds = torch.arange(S)[:, None]
    pre = a[seeds, state_of] + t[seeds, task_of]
    if objects is not None:  # the pairs' goal-object term (`FactoredQNet.first_layer_pairs`)
        pre = pre + torch.bmm(object_pairs(bits, objects, state_of, task_of), w[:, :, kt:].transpose(1, 2))
    masks = _stack_masks([m for _, _, m in items], N)
    q = q_labels(net, stack, P, pre, masks)
    return [q[s, : n[s]] for s in range(S)]


def pair_best(net: FactoredQNet, stack: Stack, P: dict, items: list) -> list:
    """`_Pairs.best` of S networks: each seed's argmax column over its labels with a valid action."""
    out = []
    for (pairs, rows, _), q in zip(items, pair_q(net, stack, P, items)):
        invalid = torch.from_numpy(~net.label_valid(pairs.valid[rows]))
        out.append(q.masked_fill(invalid, float("-inf")).max(dim=1)[1] if len(rows) else None)
    return out


# ---- one batched update -------------------------------------------------------------------------
def check_together(cfgs: list) -> None:
    """A one-line DomainError unless the runs differ in their seed (and folder) only, each seed once."""
    seeds = [c.seed for c in cfgs]
    if len(set(seeds)) != len(seeds):
        raise DomainError("--seed", f"a seed is listed twice ({','.join(map(str, seeds))})")
    first = {k: v for k, v in vars(cfgs[0]).items() if k not in ("seed", "out")}
    for c in cfgs[1:]:
        other = {k: v for k, v in vars(c).items() if k not in ("seed", "out")}
        diff = sorted(k for k in first if first[k] != other[k])
        if diff:
            raise DomainError("--seed", f"seeds trained together must share every setting; {', '.join(diff)} differ")


class SeedBatch:
    """The updates of several `Trainer`s (one per seed) done together (module docstring)."""

    def __init__(self, trainers: list):
        check_together([t.cfg for t in trainers])
        for t in trainers:
            if not isinstance(t.net, FactoredQNet):
                raise DomainError("--seed", "only the factored Q-network trains batched")
        self.trainers = trainers
        self.online = Stack([t.net for t in trainers], grad=True)
        self.target = Stack([t.target for t in trainers], grad=False)
        self.opt = StackedAdam(self.online, trainers[0].cfg.lr)
        for s, t in enumerate(trainers):
            t.opt = self.opt.of_seed(s)
            t.greedy = LiveGreedy(t.net)  # reads the parameters' new home

    def resumed(self) -> None:
        """After every trainer's `resume`: install their optimizer states in the stacked one."""
        self.opt.load_pending()

    def update(self) -> None:
        """One gradient step of every seed: lines 8-20 of Algorithm 1, batched."""
        ts, cfg = self.trainers, self.trainers[0].cfg
        net = ts[0].net
        batches = [mixed_batch(t.memory, t.demos, cfg.batch_size, cfg.demo_fraction, t.rng) for t in ts]
        plans = [
            TargetPlan(t.net, t.target, t.enc, b, cfg.gamma, cfg.horizon, t.boundary, t.slots, t.estimator)
            for t, b in zip(ts, batches)
        ]
        live = [s for s, p in enumerate(plans) if not p.empty]
        ys = [p.y for p in plans]
        if live:
            with torch.inference_mode():
                on = [(plans[s].pairs, plans[s].online_rows, plans[s].masks_at(plans[s].online_rows)) for s in live]
                tg = [(plans[s].pairs, plans[s].target_rows, plans[s].masks_at(plans[s].target_rows)) for s in live]
                sub = lambda stack: {k: v[live] for k, v in stack.params().items()} if len(live) < len(ts) else None
                P_on = sub(self.online) or self.online.params()
                P_tg = sub(self.target) or self.target.params()
                best = pair_best(net, self.online, P_on, on)
                qt = pair_q(net, self.target, P_tg, tg)
            for j, s in enumerate(live):
                ys[s] = plans[s].finish(best[j], qt[j])
        ys = [y if t.y_max is None else y.clamp_(max=t.y_max) for t, y in zip(ts, ys)]
        self.descend(batches, torch.stack(ys))

    def descend(self, batches: list, y: torch.Tensor) -> None:
        """The gradient step of every seed on its Huber loss toward its targets (line 20)."""
        ts = self.trainers
        net = ts[0].net
        seen = [t.slots.observe(b) for t, b in zip(ts, batches)]
        obs = torch.from_numpy(np.stack([o for o, _, _ in seen]))
        masks = _stack_masks([net.masks_from_bits(mb) for _, _, mb in seen], obs.shape[1])
        actions = torch.from_numpy(np.stack([b["actions"] for b in batches]))
        P = self.online.params()
        q = q_labels(net, self.online, P, _linear(obs, P["encoder.0.weight"], P["encoder.0.bias"]), masks)
        q = q.gather(2, net.lab_of_act[actions][..., None])[..., 0]  # (S, N): each row's taken action
        loss = F.smooth_l1_loss(q, y, reduction="none").mean(1)  # each seed's own mean loss
        self.opt.zero_grad()
        loss.sum().backward()  # the seeds' parameters are apart: each gets its own loss's gradient
        self.opt.step(ts[0].cfg.grad_clip)
        qm, ym, lo = q.detach().mean(1), y.mean(1), loss.detach()
        for s, t in enumerate(ts):
            t.stats["q"].append(float(qm[s]))
            t.stats["y"].append(float(ym[s]))
            t.stats["loss"].append(float(lo[s]))

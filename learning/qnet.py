"""The factored autoregressive dueling Q-network (thesis §4.1.1, Figure 4.2) and its Bellman targets.

Q(s, τ, a) = V(s, τ) + Σ_d Ā_d(s, τ, a_1..a_{d-1}; a_d): a shared encoder of the
observation, a state-value head and one advantage head per action component.
Head d sees the state embedding and learned embeddings of the earlier
components; its advantages are centred over the values of component d that are
valid given that prefix. Valid tuples in a state are exactly the factored labels
of its valid ground actions (plus AUTO, see `learning.encoding`), so Q is
computed for every ground action at once and the greedy action is the argmax
over the valid ones: exact enumeration, batched over many (state, task) pairs.

The batched plug-in calls for searches (SPEC "Values as plug-in heuristics") are
`ValueFunction.q_max(states, task)` and `ValueFunction.v_ap(states)`.
"""
from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import torch
from torch import nn

from planning.atomic import write_bytes
from planning.errors import DomainError

from .encoding import Encoding
from .plain import from_plain, load_plain, to_plain

# Transition kinds in the replay buffer: how the target bootstraps (Algorithm 1).
CONTINUE = 0     # within the task, or the per-task timeout: bootstrap the same task (§4.1.3 a)
COMPLETE = 1     # the task completed: myopic y = r, anticipatory y = r + γ V_AP(s')
TERMINAL = 2     # the domain declares the episode over (e.g. the minimal example): y = r


class ActionTable:
    """Static index tables of the factored action space: per head, the distinct prefixes and gathers."""

    def __init__(self, labels: np.ndarray, vocab_sizes: list):
        self.sizes = list(vocab_sizes)
        self.prefixes, self.flat, self.scatter, self.uses, self.pid, self.val = [], [], [], [], [], []
        n = labels.shape[0]
        for d in range(labels.shape[1]):
            keys = [tuple(r) for r in labels[:, :d].tolist()]
            uniq = list(dict.fromkeys(keys))
            pid = np.array([uniq.index(k) for k in keys], dtype=np.int64)
            flat = pid * self.sizes[d] + labels[:, d]
            # scatter[a, p*V+v] = 1: action a is a tuple with prefix p and value v at head d
            sc = np.zeros((n, len(uniq) * self.sizes[d]), dtype=np.float32)
            sc[np.arange(n), flat] = 1.0
            uses = np.zeros((n, len(uniq)), dtype=np.float32)    # action a has prefix p
            uses[np.arange(n), pid] = 1.0
            self.prefixes.append(torch.tensor(np.array(uniq, dtype=np.int64).reshape(len(uniq), d)))
            self.flat.append(torch.from_numpy(flat))
            self.scatter.append(torch.from_numpy(sc))
            self.uses.append(torch.from_numpy(uses))
            self.pid.append(torch.from_numpy(pid))
            self.val.append(torch.from_numpy(labels[:, d].astype(np.int64)))


class FactoredQNet(nn.Module):
    """Shared encoder, value head, autoregressive mask-centred advantage heads; one scalar Q per tuple.

    Head d is a one-hidden-layer MLP of [state embedding, embeddings of components
    1..d-1]; its first layer is split into a state part (computed once per row) and
    a prefix part (computed once per distinct prefix), and it is evaluated only for
    the prefixes some valid action of the row has, which is what keeps the batched
    boundary expectation cheap.
    """

    def __init__(self, obs_dim: int, labels: np.ndarray, vocab_sizes: list, hidden: int = 256,
                 embed: int = 16, head_hidden: int = 64):
        super().__init__()
        self.table = ActionTable(labels, vocab_sizes)
        self.dims = {"obs_dim": obs_dim, "hidden": hidden, "embed": embed, "head_hidden": head_hidden,
                     "vocab_sizes": list(vocab_sizes)}
        n = len(vocab_sizes)
        self.head_hidden = head_hidden
        self.encoder = nn.Sequential(nn.Linear(obs_dim, hidden), nn.ReLU(), nn.Linear(hidden, hidden), nn.ReLU())
        # one matmul for the value stream's hidden layer and every head's state part
        self.from_state = nn.Linear(hidden, (n + 1) * head_hidden)
        self.value = nn.Linear(head_hidden, 1)
        # Head d's first layer on [component embeddings 1..d-1] is a sum of one learned
        # table per earlier component (a linear map of concatenated embeddings is exactly that).
        self.prefix_tables = nn.ModuleList(
            nn.ModuleList(nn.Embedding(vocab_sizes[k], head_hidden) for k in range(d)) for d in range(1, n))
        for tables in self.prefix_tables:
            for t in tables:
                nn.init.normal_(t.weight, std=embed ** -0.5)
        self.out = nn.ModuleList(nn.Linear(head_hidden, v) for v in vocab_sizes)

    def prefix_term(self, d: int) -> torch.Tensor:
        """(P_d, head_hidden): head d's first-layer input from each distinct prefix of earlier components."""
        p = self.table.prefixes[d]
        return sum(t(p[:, k]) for k, t in enumerate(self.prefix_tables[d - 1]))

    def forward(self, obs: torch.Tensor, valid: torch.Tensor) -> torch.Tensor:
        """(N, actions) Q of every valid ground action; -inf where invalid."""
        N, H = obs.shape[0], self.head_hidden
        parts = self.from_state(self.encoder(obs))
        v = self.value(torch.relu(parts[:, :H]))[:, 0]
        rows, acts = valid.nonzero(as_tuple=True)                 # the valid tuples, all rows at once
        q = v[rows]
        for d, size in enumerate(self.table.sizes):
            P = self.table.uses[d].shape[1]
            pid, val = self.table.pid[d][acts], self.table.val[d][acts]
            flat = rows * P + pid
            used = torch.zeros(N * P, dtype=torch.bool)
            used[flat] = True                                         # (row, prefix) pairs in use
            keys = used.nonzero()[:, 0]
            inv = (torch.cumsum(used, 0) - 1)[flat]                   # each tuple's (row, prefix) slot
            z = parts[keys // P, (d + 1) * H:(d + 2) * H]                       # the state part
            if d:
                z = z + self.prefix_term(d)[keys % P]                           # + the prefix part
            adv = self.out[d](torch.relu(z))                                 # (K, V_d)
            mask = torch.zeros(adv.shape, dtype=adv.dtype).index_put((inv, val), torch.ones(()))
            mean = (adv * mask).sum(-1) / mask.sum(-1)                       # over the valid values only
            q = q + adv[inv, val] - mean[inv]
        out = torch.full((N, valid.shape[1]), float("-inf"), dtype=q.dtype)
        return out.index_put((rows, acts), q)


def masked_max(q: torch.Tensor, valid: torch.Tensor):
    """(max over valid actions, argmax) per row."""
    qm = q.masked_fill(~valid, float("-inf"))
    return qm.max(dim=1)


class NumpyQ:
    """An inference-only copy of a network in numpy: the same Q, without torch's per-call overhead.

    Acting one state at a time (greedy deployment, evaluation) is dominated by
    the framework's overhead on tiny tensors; numpy's is several times lower.
    """

    def __init__(self, net: FactoredQNet):
        g = lambda t: t.detach().numpy().astype(np.float64)
        enc = [m for m in net.encoder if isinstance(m, nn.Linear)]
        self.layers = [(g(m.weight).T, g(m.bias)) for m in enc]
        self.state_w, self.state_b = g(net.from_state.weight).T, g(net.from_state.bias)
        self.value_w, self.value_b = g(net.value.weight).T, g(net.value.bias)
        self.out = [(g(m.weight).T, g(m.bias)) for m in net.out]
        with torch.no_grad():
            self.prefix = [None] + [g(net.prefix_term(d)) for d in range(1, len(net.table.sizes))]
        self.H, self.table = net.head_hidden, net.table
        self.pid = [t.numpy() for t in net.table.pid]
        self.val = [t.numpy() for t in net.table.val]

    def __call__(self, obs: np.ndarray, valid: np.ndarray) -> np.ndarray:
        """(N, actions) Q, -inf where invalid (as FactoredQNet.forward)."""
        h = obs.astype(np.float64)
        for w, b in self.layers:
            h = np.maximum(h @ w + b, 0.0)
        parts = h @ self.state_w + self.state_b
        H, N = self.H, len(obs)
        v = (np.maximum(parts[:, :H], 0.0) @ self.value_w + self.value_b)[:, 0]
        rows, acts = np.nonzero(valid)
        q = v[rows]
        for d, size in enumerate(self.table.sizes):
            P = self.table.uses[d].shape[1]
            pid, val = self.pid[d][acts], self.val[d][acts]
            flat = rows * P + pid
            used = np.zeros(N * P, dtype=bool)
            used[flat] = True
            keys = np.flatnonzero(used)
            inv = (np.cumsum(used) - 1)[flat]
            z = parts[keys // P, (d + 1) * H:(d + 2) * H]
            if d:
                z = z + self.prefix[d][keys % P]
            w, b = self.out[d]
            adv = np.maximum(z, 0.0) @ w + b
            mask = np.zeros(adv.shape)
            mask[inv, val] = 1.0
            mean = (adv * mask).sum(-1) / mask.sum(-1)
            q = q + adv[inv, val] - mean[inv]
        out = np.full(valid.shape, -np.inf)
        out[rows, acts] = q
        return out


class ValueFunction:
    """A trained Q-network bound to a layout's encoding: greedy actions, q_max and v_ap, batched.

    Inference runs on a numpy snapshot of the weights taken at construction.
    """

    def __init__(self, net: FactoredQNet, enc: Encoding, gamma: float = 0.97):
        """`gamma`: the discount the network was trained with (the search discounts its prefix costs by it)."""
        self.net, self.enc, self.gamma = net, enc, gamma
        self.fast = NumpyQ(net)

    def q_values(self, states, task) -> np.ndarray:
        """(N, actions) Q of (state, task) for every ground action and AUTO; -inf where invalid."""
        packed = self.enc.pack(states)
        tasks = np.full(len(packed), _task_index(task), dtype=np.int64)
        return self.fast(self.enc.observe(packed, tasks), self.enc.valid_for(packed, tasks))

    def greedy(self, states, task) -> np.ndarray:
        """The greedy ground action (or AUTO) per state for one task."""
        return self.q_values(states, task).argmax(1)

    def q_max(self, states, task) -> np.ndarray:
        """max_a Q(s, τ, a) per state: the value of a state for the current task."""
        return self.q_values(states, task).max(1)

    def v_ap(self, states) -> np.ndarray:
        """V_AP(s) = Σ_τ P(τ) max_a Q(s, τ, a) per state: the preparedness value (Eq. 3.8)."""
        packed = self.enc.pack(states)
        if len(packed) == 0:
            return np.zeros(0)
        obs, valid = _pairs(self.enc, packed)
        v = self.fast(obs, valid).max(1).reshape(len(packed), len(self.enc.support))
        return v @ self.enc.task_prob[self.enc.support]


def _task_index(task) -> int:
    return task if isinstance(task, (int, np.integer)) else task.index


def _pairs(enc: Encoding, packed: np.ndarray):
    """Every (state, task in the support) pair of a batch: observations and validity, masks once per state."""
    support = enc.support
    n, k = len(packed), len(support)
    app = enc.applicable(packed)
    sat = enc.satisfied_all(packed)[:, support]
    rows = np.repeat(np.arange(n), k)
    tasks = np.tile(support, n)
    valid = enc.valid(app[rows], sat.reshape(-1))
    return enc.observe(packed[rows], tasks), valid


def preparedness(online: nn.Module, target: nn.Module, enc: Encoding, packed: np.ndarray) -> np.ndarray:
    """Σ_τ P(τ) Q_target(s, τ, argmax_a Q_online(s, τ, a)) per state (with online = target: V_AP)."""
    if len(packed) == 0:
        return np.zeros(0)
    obs, valid = _pairs(enc, packed)
    obs, valid = torch.from_numpy(obs), torch.from_numpy(valid)
    with torch.no_grad():
        _, best = masked_max(online(obs, valid), valid)
        qt = target(obs, valid) if target is not online else online(obs, valid)
        v = qt.gather(1, best[:, None])[:, 0].reshape(len(packed), len(enc.support)).double()
    return (v @ torch.from_numpy(enc.task_prob[enc.support])).numpy()


class BoundaryCache:
    """Target-network values of the boundary pairs, per completion state, valid until the next target sync.

    The anticipatory target needs Q_target(s', τ', ·) for every task of the support
    at every replayed completion state s'. The target network only changes at a
    sync, and a completion state is replayed several times between syncs (demos
    most of all), so those rows are computed once per sync; the online argmax is
    recomputed every update, so the Double-DQN target stays exact. Clear it
    whenever the target network changes.
    """

    def __init__(self, max_states: int = 4096):   # ~50 KB a state (two-room)
        self.max_states, self.entries = max_states, {}

    def __len__(self) -> int:
        return len(self.entries)

    def clear(self) -> None:
        """Forget every entry (call at each target sync)."""
        self.entries.clear()


def _boundary_inputs(enc: Encoding, states: np.ndarray, cache: BoundaryCache | None):
    """Observations, validity and cached target values (None where missing) of each state's support pairs."""
    keys = [s.tobytes() for s in states]
    hit = [cache.entries.get(k) if cache is not None else None for k in keys]
    miss = [j for j, e in enumerate(hit) if e is None]
    k = len(enc.support)
    fresh = {}
    if miss:
        obs, valid = _pairs(enc, states[miss])
        for i, j in enumerate(miss):
            fresh[j] = (obs[i * k:(i + 1) * k], valid[i * k:(i + 1) * k])
    parts = [fresh[j] if hit[j] is None else hit[j][:2] for j in range(len(states))]
    return keys, parts, hit, miss


def td_targets(online: nn.Module, target: nn.Module, enc: Encoding, batch: dict, gamma: float,
               horizon: str, cache: BoundaryCache | None = None) -> torch.Tensor:
    """Double-DQN targets of Algorithm 1 (lines 11-17) for a batch of stored transitions.

    batch: next_states (N, W) uint64, tasks (N,), rewards (N,), kinds (N,) (CONTINUE /
    COMPLETE / TERMINAL). The online net picks, the target net values. The
    same-task pairs and the boundary pairs (every completion's s' with every task
    of the support) go through each network in one batched call; with a cache,
    the target net sees only the boundary states it has not valued since the last sync.
    """
    if horizon not in ("myopic", "anticipatory"):
        raise DomainError("--horizon", f"'{horizon}' is neither myopic nor anticipatory")
    y = torch.as_tensor(batch["rewards"], dtype=torch.float32).clone()
    kinds = np.asarray(batch["kinds"])
    nxt = batch["next_states"]
    cont = np.flatnonzero(kinds == CONTINUE)
    comp = np.flatnonzero(kinds == COMPLETE) if horizon == "anticipatory" else cont[:0]
    if not len(cont) and not len(comp):
        return y
    tasks = np.asarray(batch["tasks"])[cont]
    obs, valid = [enc.observe(nxt[cont], tasks)], [enc.valid_for(nxt[cont], tasks)]
    n, k = len(cont), len(enc.support)
    keys, hit, miss = [], [], []
    if len(comp):
        keys, parts, hit, miss = _boundary_inputs(enc, nxt[comp], cache)
        obs += [o for o, _ in parts]
        valid += [v for _, v in parts]
    obs_all, valid_all = np.concatenate(obs), np.concatenate(valid)
    rows_t = np.concatenate([np.arange(n)] + [n + j * k + np.arange(k) for j in miss]).astype(np.int64)
    with torch.inference_mode():
        _, best = masked_max(online(torch.from_numpy(obs_all), torch.from_numpy(valid_all)), torch.from_numpy(valid_all))
        fresh = target(torch.from_numpy(obs_all[rows_t]), torch.from_numpy(valid_all[rows_t])).numpy()
    qt = np.empty((len(obs_all), enc.n_actions), dtype=np.float32)
    qt[rows_t] = fresh
    for j, e in enumerate(hit):
        if e is not None:
            qt[n + j * k:n + (j + 1) * k] = e[2]
    if cache is not None:
        for j in miss:
            if len(cache.entries) < cache.max_states:
                sl = slice(n + j * k, n + (j + 1) * k)
                cache.entries[keys[j]] = (obs_all[sl].copy(), valid_all[sl].copy(), qt[sl].copy())
    picked = torch.from_numpy(qt[np.arange(len(qt)), best.numpy()])
    y[torch.from_numpy(cont)] += gamma * picked[:n]
    if len(comp):
        p = torch.from_numpy(enc.task_prob[enc.support]).float()
        y[torch.from_numpy(comp)] += gamma * (picked[n:].reshape(len(comp), k) @ p)
    return y


# ---- checkpoints ---------------------------------------------------------
def save_checkpoint(path, payload: dict) -> Path:
    """Write a torch checkpoint atomically (a temporary file beside it, then os.replace), in plain
    types only (`learning.plain`): it loads with weights_only=True."""
    buf = io.BytesIO()
    torch.save(to_plain(payload), buf)
    return write_bytes(path, buf.getvalue())


def read_checkpoint(path) -> dict:
    """A checkpoint's payload, loaded with weights_only=True (nothing in the file runs); a missing,
    corrupt, foreign or hostile file is a one-line DomainError naming it."""
    path = Path(path)
    payload = load_plain(path, "checkpoint")
    if not isinstance(payload, dict) or "net" not in payload or "dims" not in payload:
        raise DomainError(path, "not a Q-network checkpoint (no 'net' or 'dims')")
    return from_plain(payload)


def network_payload(net: FactoredQNet, enc: Encoding, extra: dict | None = None) -> dict:
    """The minimal checkpoint of a network: weights, sizes and the layout signature."""
    return {"net": net.state_dict(), "dims": net.dims, "signature": enc.signature(), **(extra or {})}


def build_network(enc: Encoding, hidden: int = 256, embed: int = 16, head_hidden: int = 64) -> FactoredQNet:
    """A fresh network for a layout's encoding."""
    return FactoredQNet(enc.obs_dim, enc.labels, [len(v) for v in enc.vocab], hidden, embed, head_hidden)


def load_value_function(path, model) -> ValueFunction:
    """The greedy value of a checkpoint, checked against the layout it is used on."""
    payload = read_checkpoint(path)
    enc = Encoding(model)
    sig = payload.get("signature", {})
    mine = enc.signature()
    if sig != mine:
        diff = [k for k in mine if sig.get(k) != mine[k]]
        raise DomainError(path, f"trained for {sig.get('domain')}/{sig.get('layout')}, "
                                f"not {mine['domain']}/{mine['layout']} (differs in {', '.join(diff)})")
    d = payload["dims"]
    net = FactoredQNet(d["obs_dim"], enc.labels, d["vocab_sizes"], d["hidden"], d["embed"], d["head_hidden"])
    try:
        net.load_state_dict(payload["net"])
    except RuntimeError as e:
        raise DomainError(path, f"weights do not fit the network ({str(e).splitlines()[0]})") from None
    net.eval()
    return ValueFunction(net, enc, float(payload.get("config", {}).get("gamma", 0.97)))

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
from torch.nn import functional as F

from planning.atomic import write_bytes
from planning.errors import DomainError

from .encoding import Encoding
from .plain import from_plain, full_precision, load_plain, to_plain

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
    a prefix part (computed once per distinct prefix). Every row is evaluated densely
    at the *live* prefixes only (`_plan_heads`), per distinct label, with no per-row
    index bookkeeping: the same Q and gradients as evaluating each valid tuple's
    prefixes, at close to the cost of a plain MLP. `forward_pairs` splits the
    encoder's first layer too, for the boundary rows that repeat a state per task.
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
        self._plan_heads()

    def prefix_term(self, d: int) -> torch.Tensor:
        """(P_d, head_hidden): head d's first-layer input from each distinct prefix of earlier components."""
        p = self.table.prefixes[d]
        return sum(t(p[:, k]) for k, t in enumerate(self.prefix_tables[d - 1]))

    def _plan_heads(self) -> None:
        """Static tables of the dense evaluation (`q_labels`).

        Ground actions that share a factored label share their Q, so Q is computed per
        distinct label and copied to the actions. A head is evaluated only at its *live*
        prefixes, those followed by two or more values in the label table: at any other prefix
        the one value's centred advantage is A - A = 0 exactly, in value and gradient (the
        restaurant's last head has no live prefix; 10 of its 88 prefixes are live). Each live
        (head, prefix) is an *instance*; all instances go through one matmul against the live
        heads' stacked output layers, each keeps its own head's columns (padded to the widest
        head), and one 0/1 matrix sums their centred advantages onto the labels.
        """
        t, H = self.table, self.head_hidden
        labels = np.stack([v.numpy() for v in t.val], 1)
        uniq, first, lab_of_act = np.unique(labels, axis=0, return_index=True, return_inverse=True)
        A, L = len(labels), len(uniq)
        self.lab_of_act = torch.from_numpy(lab_of_act.reshape(-1).astype(np.int64))
        self.act_by_label = np.argsort(lab_of_act.reshape(-1), kind="stable")        # actions grouped by label
        self.label_start = np.searchsorted(lab_of_act.reshape(-1)[self.act_by_label], np.arange(len(uniq)))
        inst = []                                       # (head, prefix id, values that follow it)
        for d, V in enumerate(t.sizes):
            pid, val = t.pid[d].numpy()[first], uniq[:, d]
            for p in range(t.uses[d].shape[1]):
                vals = np.unique(val[pid == p])
                if len(vals) >= 2:
                    inst.append((d, p, vals))
        heads = sorted({d for d, _, _ in inst})
        I, Vm = len(inst), max((t.sizes[d] for d in heads), default=1)
        self.n_inst, self.v_max = I, Vm
        self.inst_head = torch.tensor([d for d, _, _ in inst], dtype=torch.int64)
        self.state_width = (max(heads, default=-1) + 2) * H      # value stream and heads up to the last live
        # output rows: the live heads' weights stacked, then a zero row for the padding
        off = dict(zip(heads, np.cumsum([0] + [t.sizes[d] for d in heads])[:-1].tolist()))
        self.out_heads, pad = heads, sum(t.sizes[d] for d in heads)
        out_col = np.full((I, Vm), pad, dtype=np.int64)
        for i, (d, _, _) in enumerate(inst):
            out_col[i, :t.sizes[d]] = off[d] + np.arange(t.sizes[d])
        self.out_col = torch.from_numpy(out_col[:, None, :])                            # (I, 1, V)
        # prefix part: one bag of (table, component) rows per instance, in the stacked prefix tables
        tables = [(d, k) for d in heads if d for k in range(d)]
        toff = dict(zip(tables, np.cumsum([0] + [t.sizes[k] for _, k in tables])[:-1].tolist()))
        self.prefix_mods = tuple(self.prefix_tables[d - 1][k] for d, k in tables)
        self.out_mods = tuple(self.out[d] for d in heads)
        bag, bag_off = [], []
        for d, p, _ in inst:
            bag_off.append(len(bag))
            bag += [toff[(d, k)] + int(c) for k, c in enumerate(t.prefixes[d][p].tolist())]
        self.bag, self.bag_off = torch.tensor(bag, dtype=torch.int64), torch.tensor(bag_off, dtype=torch.int64)
        self.bag_of = torch.zeros(I, sum(t.sizes[k] for _, k in tables))           # instance -> its prefix rows
        for i, (lo, hi) in enumerate(zip(bag_off, bag_off[1:] + [len(bag)])):
            self.bag_of[i, bag[lo:hi]] = 1.0
        # (instance, value) slots: which labels use them
        slot_lab = np.zeros((L, I * Vm), dtype=np.float32)
        where = {(d, p): i for i, (d, p, _) in enumerate(inst)}
        for d in heads:
            pid = t.pid[d].numpy()[first]
            for l in range(L):
                i = where.get((d, int(pid[l])))
                if i is not None:
                    slot_lab[l, i * Vm + uniq[l, d]] = 1.0
        self.slot_act = torch.from_numpy(slot_lab[lab_of_act.reshape(-1)].T.copy())     # (slots, A)
        self.lab_of_slot = torch.from_numpy(slot_lab.T.copy())                           # (slots, L)

    def head_masks(self, valid: torch.Tensor) -> tuple:
        """(I, N, V) 0/1 mask of the valid values after each instance's prefix, and its (I, N, 1)
        count (at least 1): what the advantages are centred over. It depends on validity only, so
        one call serves the online and the target network (`select` takes rows of it)."""
        m = (self.slot_act @ valid.to(torch.float32).T).clamp_(max=1.0)          # (slots, N)
        m = m.view(self.n_inst, self.v_max, len(valid)).transpose(1, 2)
        return m, m.sum(-1, keepdim=True).clamp_(min=1.0)

    def mask_bits(self, valid) -> np.ndarray:
        """(N, instances * V) bool: `head_masks` of rows with this validity in a compact form, to keep
        beside the validity it depends on (`masks_from_bits` turns it back)."""
        m = self.slot_act @ torch.as_tensor(valid).to(torch.float32).T                    # (slots, N)
        return (m > 0).T.numpy()

    def masks_from_bits(self, bits: np.ndarray) -> tuple:
        """`head_masks` from `mask_bits`: the same tensors, without the product over every action."""
        m = torch.from_numpy(bits.astype(np.float32)).view(len(bits), self.n_inst, self.v_max).transpose(0, 1)
        return m, m.sum(-1, keepdim=True).clamp_(min=1.0)

    def label_valid(self, valid: np.ndarray) -> np.ndarray:
        """(N, labels) bool: which factored labels have a valid ground action in each row."""
        return np.logical_or.reduceat(valid[:, self.act_by_label], self.label_start, axis=1)

    @staticmethod
    def select_masks(masks: tuple, rows: torch.Tensor) -> tuple:
        """The head masks of some rows."""
        return tuple(x.index_select(1, rows) for x in masks)

    def q_labels(self, pre: torch.Tensor, masks: tuple) -> torch.Tensor:
        """(N, labels) Q of every factored label from the first layer's pre-activations (a label
        invalid in a row gets a finite, meaningless value).

        Only the instances where some row has two or more valid values are evaluated: at a
        prefix with one valid value the centred advantage of that value is A - A = 0 exactly,
        so the others add nothing to any valid label (restaurant minibatches use 3 of 10).
        """
        H, e, w = self.head_hidden, self.encoder, self.state_width
        parts = F.linear(e[3](e[2](e[1](pre))), self.from_state.weight[:w], self.from_state.bias[:w])
        v = self.value(torch.relu(parts[:, :H]))                                       # (N, 1)
        N, L = parts.shape[0], self.lab_of_slot.shape[1]
        m, count = masks
        act = (count[:, :, 0] >= 2).any(1).nonzero()[:, 0]                           # instances in use
        if not len(act):
            return v.expand(-1, L)
        if len(act) < self.n_inst:
            m, count = m.index_select(0, act), count.index_select(0, act)
        z = parts[:, H:].view(N, w // H - 1, H).transpose(0, 1).index_select(0, self.inst_head[act])   # (K, N, H)
        if self.prefix_mods:
            tabs = torch.cat([t.weight for t in self.prefix_mods])
            pref = F.embedding_bag(self.bag, tabs, self.bag_off, mode="sum").index_select(0, act)
            z.add_(pref[:, None])                                                         # + the prefix parts
        w_out = torch.cat([o.weight for o in self.out_mods] + [z.new_zeros(1, H)])
        b_out = torch.cat([o.bias for o in self.out_mods] + [z.new_zeros(1)])
        adv = F.linear(z.relu_(), w_out, b_out).gather(2, self.out_col[act].expand(-1, N, -1))   # (K, N, V)
        c = adv - (adv * m).sum(-1, keepdim=True) / count                              # centred over the valid values
        slots = self.lab_of_slot.view(self.n_inst, self.v_max, L).index_select(0, act).reshape(-1, L)
        return torch.addmm(v, c.transpose(0, 1).reshape(N, -1), slots)

    def forward(self, obs: torch.Tensor, valid: torch.Tensor, masks: tuple | None = None) -> torch.Tensor:
        """(N, actions) Q of every valid ground action; -inf where invalid."""
        masks = self.head_masks(valid) if masks is None else masks
        q = self.q_labels(self.encoder[0](obs), masks).index_select(1, self.lab_of_act)
        return q.masked_fill(~valid, float("-inf"))

    def q_taken(self, obs: torch.Tensor, valid: torch.Tensor, actions: torch.Tensor,
                masks: tuple | None = None) -> torch.Tensor:
        """(N,) Q of each row's taken action, which is valid there (`forward` gathered, without the
        copy to every action)."""
        q = self.q_labels(self.encoder[0](obs), self.head_masks(valid) if masks is None else masks)
        return q.gather(1, self.lab_of_act[actions][:, None])[:, 0]

    def first_layer_pairs(self, bits: torch.Tensor, task_feat: torch.Tensor, state_of: torch.Tensor,
                          task_of: torch.Tensor) -> torch.Tensor:
        """The first layer's pre-activations of the observations [bits[state_of], task_feat[task_of]],
        split: its state part once per state, its task part once per task (the 42-48 task rows of a
        boundary state share one state projection)."""
        w, b, k = self.encoder[0].weight, self.encoder[0].bias, bits.shape[1]
        return F.linear(bits, w[:, :k]).index_select(0, state_of) + F.linear(task_feat, w[:, k:], b).index_select(0, task_of)

    def forward_pairs(self, bits: torch.Tensor, task_feat: torch.Tensor, state_of: torch.Tensor,
                      task_of: torch.Tensor, valid: torch.Tensor, masks: tuple | None = None) -> torch.Tensor:
        """`forward` of the observations [bits[state_of], task_feat[task_of]] (`first_layer_pairs`)."""
        masks = self.head_masks(valid) if masks is None else masks
        q = self.q_labels(self.first_layer_pairs(bits, task_feat, state_of, task_of), masks)
        return q.index_select(1, self.lab_of_act).masked_fill(~valid, float("-inf"))


def masked_max(q: torch.Tensor, valid: torch.Tensor):
    """(max over valid actions, argmax) per row."""
    qm = q.masked_fill(~valid, float("-inf"))
    return qm.max(dim=1)


class LiveGreedy:
    """The greedy action of one (state, task) under a FactoredQNet's current weights, in float32 numpy.

    Acting runs the network on one row per environment step, where torch's per-operation
    overhead is most of the cost. This reads the parameters through numpy views, so
    optimizer steps and load_state_dict (both in place) are seen without a copy, and
    evaluates `FactoredQNet.q_labels` for that row with a dozen numpy operations. Q is
    the forward's up to float32 rounding.
    """

    def __init__(self, net: FactoredQNet):
        view = lambda p: p.detach().numpy()
        e, w, H = net.encoder, net.state_width, net.head_hidden
        self.l1, self.l2 = (view(e[0].weight), view(e[0].bias)), (view(e[2].weight), view(e[2].bias))
        self.ws, self.bs = view(net.from_state.weight)[:w], view(net.from_state.bias)[:w]
        self.wv, self.bv = view(net.value.weight)[0], view(net.value.bias)
        self.tabs = [view(t.weight) for t in net.prefix_mods]
        self.outs = [(view(o.weight), view(o.bias)) for o in net.out_mods]
        self.H, self.I, self.inst_head = H, net.n_inst, net.inst_head.numpy()
        self.bag_of = net.bag_of.numpy()                                 # instance -> its prefix rows
        self.out_col = net.out_col[:, 0].numpy()
        self.slot_act, self.lab_of_slot = net.slot_act.numpy(), net.lab_of_slot.numpy()
        self.lab_of_act = net.lab_of_act.numpy()

    def __call__(self, obs: np.ndarray, valid: np.ndarray) -> int:
        """argmax over the valid actions of Q(obs) (obs: (obs_dim,) float32; valid: (actions,) bool)."""
        (w1, b1), (w2, b2), H = self.l1, self.l2, self.H
        h = np.maximum(w1 @ obs + b1, 0.0)
        h = np.maximum(w2 @ h + b2, 0.0)
        parts = self.ws @ h + self.bs
        q = np.full(len(self.lab_of_slot[0]), self.wv @ np.maximum(parts[:H], 0.0) + self.bv[0], dtype=np.float32)
        if self.I:
            z = parts[H:].reshape(-1, H)[self.inst_head]
            if self.tabs:
                z += self.bag_of @ np.concatenate(self.tabs)
            w_out = np.concatenate([o for o, _ in self.outs] + [np.zeros((1, H), np.float32)])
            b_out = np.concatenate([b for _, b in self.outs] + [np.zeros(1, np.float32)])
            adv = np.take_along_axis(np.maximum(z, 0.0) @ w_out.T + b_out, self.out_col, 1)   # (I, V)
            m = np.minimum(self.slot_act @ valid.astype(np.float32), 1.0).reshape(adv.shape)
            c = adv - ((adv * m).sum(1) / np.maximum(m.sum(1), 1.0))[:, None]
            q += c.reshape(-1) @ self.lab_of_slot
        qa = np.where(valid, q[self.lab_of_act], -np.inf)
        return int(qa.argmax())


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


class BatchedQ:
    """max_a Q(s, τ, a) of many int states at once: the searches' q_max and V_AP.

    The same numbers as `NumpyQ` followed by a max over the valid actions, up to
    float32 rounding. A search asks for a dozen states at a time with its own
    work in between, so a call's cost is mostly its number of numpy operations
    and the weights it reads; both are cut down:
    - the features are the atom bits plus a constant 1 (a byte -> 8 floats
      table), and one matmul with a per-task matrix gives layer 1 (the task
      part and the biases in the constant's row) together with every
      precondition variant's and task goal binding's test: a column of +1 on
      its positive atoms, -1 on its negative ones and 1 - #positive on the
      constant is 1 where the test holds and at most 0 elsewhere, so the ReLU
      of layer 1 also yields the validity masks, exactly. The constant rides
      along as a feature through the layers and carries their biases;
    - a head's centred advantage at a prefix with fewer than two valid values is
      A - A = 0, so only the *live* prefixes are evaluated, those followed by two
      or more values in the label table (10 of the restaurant's 90), each for
      every row, all heads in one matmul;
    - which (live prefix, value) slots a row's valid actions use, their masked
      means and each precondition variant's Q - V are small dense matmuls
      against fixed 0/1 tables, and the max runs over the applicable variants
      (an action's variants share its Q). A state whose task already holds has
      AUTO alone valid: its Q is V.
    Float32 throughout except the value stream, V being the largest term (up to
    240 in the two-room, where float32's step is 1.5e-5).
    """

    def __init__(self, net: FactoredQNet, enc: Encoding, chunk: int = 4096):
        """`chunk`: the most (state, task) rows valued in one pass (V_AP's pairs go in chunks)."""
        g = lambda t: t.detach().numpy().astype(np.float64)
        f = lambda a: np.ascontiguousarray(a, dtype=np.float32)
        lin = [m for m in net.encoder if isinstance(m, nn.Linear)]
        n, H, nd = enc.n_atoms, net.head_hidden, len(net.table.sizes)
        hid = lin[0].weight.shape[0]
        self.H, self.hid, self.chunk, self.enc = H, hid, chunk, enc
        self.nbytes = nb = -(-n // 8)
        self.one = 1 << (8 * nb)                   # the constant feature: bit 0 of one more byte
        self.byte_bits = f(np.unpackbits(np.arange(256, dtype=np.uint8)[:, None], axis=1, bitorder="little"))
        # layer 1 and the tests: rows = atom bits (8 per byte) + the constant byte's 8 bits
        bm = enc.bm
        pos = np.concatenate([bm.pre_pos, enc.goal_pos]).astype("<u8")
        neg = np.concatenate([bm.pre_neg, enc.goal_neg]).astype("<u8")
        J, self.n_var = len(pos), len(bm.pre_pos)
        bits_of = lambda w: np.unpackbits(w.view(np.uint8).reshape(len(w), -1), axis=1,
                                          bitorder="little")[:, :nb * 8].astype(np.float64)
        P, Nn = bits_of(pos), bits_of(neg)                                 # (J, atom rows)
        w1 = g(lin[0].weight).T                                            # (obs_dim, hidden)
        c = nb * 8                                                         # the constant's row
        base = np.zeros((nb * 8 + 8, hid + 1 + J))
        base[:n, :hid] = w1[:n]
        base[c, :hid] = g(lin[0].bias)
        base[c, hid] = 1.0                                                 # the constant, as a feature
        base[:nb * 8, hid + 1:] = (P - Nn).T
        base[c, hid + 1:] = 1.0 - P.sum(1)
        self.l1_base = f(base)
        self.task_part = enc.task_feat.astype(np.float64) @ w1[n:]        # (tasks, hidden)
        self.l1_task: dict = {}                                            # task -> its layer-1 matrix
        self.t0, self.g0 = hid + 1, hid + 1 + self.n_var                  # test columns: variants, goals
        aug = lambda w, b: np.vstack([w, b[None]])                         # the constant's row: the bias
        self.w2 = f(np.hstack([aug(g(lin[1].weight).T, g(lin[1].bias)), np.eye(hid + 1)[:, -1:]]))
        ws, bs = g(net.from_state.weight).T, g(net.from_state.bias)
        const = np.zeros((hid + 1, 1))
        const[-1] = 1.0
        self.ws_v = np.hstack([aug(ws[:, :H], bs[:H]), const])             # the value stream, float64
        self.value_w = np.append(g(net.value.weight)[0], g(net.value.bias)[0])
        T = len(enc.task_feat)
        self.goal_cols = [self.g0 + np.flatnonzero(enc.goal_owner == t) for t in range(T)]
        self.goal_of = np.zeros((J - self.n_var, T), np.float32)
        self.goal_of[np.arange(J - self.n_var), enc.goal_owner] = 1.0
        # the live prefixes ("segments") and their (segment, value) columns
        tab = net.table
        labels = np.stack([v.numpy() for v in tab.val], 1)
        pids = np.stack([p.numpy() for p in tab.pid], 1)
        segs = []                                       # (head, prefix id, its values in the label table)
        for d in range(nd):
            for p in range(tab.uses[d].shape[1]):
                vals = np.unique(labels[pids[:, d] == p, d])
                if len(vals) >= 2:
                    segs.append((d, p, vals))
        live = sorted({d for d, _, _ in segs})
        self.n_live = len(live)
        self.segs, self.live, self._net = segs, live, net       # for the compiled engine (NativeQ)
        self.ws_h = f(np.hstack([np.hstack([aug(ws[:, (1 + d) * H:(2 + d) * H], bs[(1 + d) * H:(2 + d) * H]),
                                            const]) for d in live]))      # each live head's part + 1
        off = dict(zip(live, np.cumsum([0] + [tab.sizes[d] for d in live])[:-1].tolist()))
        ccat = sum(tab.sizes[d] for d in live)
        w_cat = np.zeros((H + 1, ccat))
        for d in live:
            w_cat[:, off[d]:off[d] + tab.sizes[d]] = aug(g(net.out[d].weight).T, g(net.out[d].bias))
        self.w_cat = f(w_cat)
        with torch.no_grad():
            pref = {d: g(net.prefix_term(d)) for d in live if d}
        S = len(segs)
        self.seg_head = np.array([live.index(d) for d, _, _ in segs], dtype=np.intp)
        self.seg_pref = f(np.hstack([np.stack([pref[d][p] if d else np.zeros(H) for d, p, _ in segs])
                                     .reshape(S, H), np.zeros((S, 1))]))
        col_sel, col_seg, col_of = [], [], {}
        for s, (d, p, vals) in enumerate(segs):
            for v in vals.tolist():
                col_of[(d, p, v)] = len(col_sel)
                col_sel.append(s * ccat + off[d] + v)
                col_seg.append(s)
        C = len(col_sel)
        self.col_sel = np.array(col_sel, dtype=np.intp)
        self.seg_of = np.zeros((C, S), np.float32)                         # column -> its segment
        self.seg_of[np.arange(C), col_seg] = 1.0
        self.s_var = np.zeros((self.n_var, C), np.float32)                 # variant -> its action's columns
        for j, a in enumerate(bm.op_action.tolist()):
            for d in live:
                k = col_of.get((d, int(pids[a, d]), int(labels[a, d])))
                if k is not None:
                    self.s_var[j, k] = 1.0
        seg_var = (self.s_var @ self.seg_of).T                            # (segments, variants) 0/1
        self.g_adv = f(np.concatenate([self.s_var.T, -seg_var]))          # [columns | means] -> Q - V
        self.support = enc.support
        self.prob = enc.task_prob[enc.support]

    # ---- inputs ------------------------------------------------------------
    def features(self, states) -> np.ndarray:
        """(N, atom rows + 8) float32: the atom bits of int states (or of a packed uint64 array), then the constant."""
        nb = self.nbytes
        if not (isinstance(states, np.ndarray) and states.dtype == np.uint64):
            one = self.one
            try:
                raw = np.frombuffer(b"".join([(s | one).to_bytes(nb + 1, "little") for s in states]),
                                    dtype=np.uint8).reshape(-1, nb + 1)
                return self.byte_bits.take(raw, axis=0).reshape(len(raw), -1)
            except (TypeError, AttributeError, OverflowError):   # not Python ints: the general packing
                states = self.enc.pack(states)
        words = np.ascontiguousarray(states.reshape(-1, self.enc.n_words), dtype="<u8")
        raw = np.ones((len(words), nb + 1), np.uint8)
        raw[:, :nb] = words.view(np.uint8).reshape(len(words), -1)[:, :nb]
        return self.byte_bits.take(raw, axis=0).reshape(len(raw), -1)

    def layer1(self, task: int) -> np.ndarray:
        """A task's layer-1-and-tests matrix, its goal's bindings last (made once per task)."""
        w = self.l1_task.get(task)
        if w is None:
            w = np.concatenate([self.l1_base[:, :self.g0], self.l1_base[:, self.goal_cols[task]]], axis=1)
            w[-8, :self.hid] += self.task_part[task]
            w = self.l1_task[task] = np.ascontiguousarray(w, dtype=np.float32)
        return w

    # ---- the network -------------------------------------------------------
    def values(self, h1: np.ndarray, okf: np.ndarray):
        """Per row, from layer 1 (with the constant) and the variants' 0/1 validity: the max of Q - V over the
        applicable variants (float32, -inf where none) and V (float64)."""
        N, H = len(h1), self.H
        h = h1 @ self.w2
        np.maximum(h, 0, out=h)
        pv = h.astype(np.float64) @ self.ws_v
        np.maximum(pv, 0, out=pv)
        v = pv @ self.value_w
        z = (h @ self.ws_h).reshape(N, self.n_live, H + 1).take(self.seg_head, axis=1)
        z += self.seg_pref
        np.maximum(z, 0, out=z)
        y = (z.reshape(-1, H + 1) @ self.w_cat).reshape(N, -1).take(self.col_sel, axis=1)   # advantages
        present = okf @ self.s_var
        np.minimum(present, 1.0, out=present)                              # the valid (prefix, value) slots
        count = present @ self.seg_of
        np.maximum(count, 1.0, out=count)
        present *= y
        mean = present @ self.seg_of
        mean /= count
        q = np.concatenate([y, mean], axis=1) @ self.g_adv                # (N, variants) Σ centred A
        return np.maximum.reduce(q, axis=1, where=okf > 0, initial=-np.inf), v

    def q_max(self, states, task: int) -> np.ndarray:
        """max_a Q(s, task, a) per state (a task index)."""
        if len(states) == 0:
            return np.zeros(0)
        a = self.features(states) @ self.layer1(task)
        np.maximum(a, 0, out=a)
        adv, v = self.values(a[:, :self.t0], a[:, self.t0:self.g0])
        goals = a[:, self.g0:]
        if goals.any():
            adv[goals.any(1)] = 0.0                # AUTO alone: every head's advantage centres to 0
        return v + adv

    def v_ap(self, states) -> np.ndarray:
        """Σ_τ P(τ) max_a Q(s, τ, a) over the task support, per state."""
        if len(states) == 0:
            return np.zeros(0)
        a = self.features(states) @ self.l1_base                          # no task part yet
        hid, sup, K = self.hid, self.support, len(self.support)
        tests = np.maximum(a[:, self.t0:], 0)
        okf = np.ascontiguousarray(tests[:, :self.n_var])
        sat = (tests[:, self.n_var:] @ self.goal_of[:, sup]) > 0          # (N, K)
        tasks = np.zeros((K, hid + 1), np.float32)
        tasks[:, :hid] = self.task_part[sup]
        out = np.empty((len(a), K))
        step = max(1, self.chunk // max(K, 1))
        for lo in range(0, len(a), step):
            hi = min(lo + step, len(a))
            h1 = np.maximum(a[lo:hi, None, :self.t0] + tasks, 0).reshape((hi - lo) * K, -1)
            adv, v = self.values(h1, np.repeat(okf[lo:hi], K, axis=0))
            adv[sat[lo:hi].reshape(-1)] = 0.0
            out[lo:hi] = (v + adv).reshape(hi - lo, K)
        return out @ self.prob


class NativeQ:
    """`BatchedQ.q_max` and `v_ap` compiled (learning/_qnet.c): the same function, each state valued on its own.

    A BLAS product's rounding depends on the batch (its size and a row's place
    in it), so BatchedQ's value of a state moves in its last bits (up to ~2e-5
    on the restaurant) with the states it is valued with. Here every state's
    sums run in a fixed order, so its value is a function of the state alone,
    the same in any batch and on any x86 machine (no fused multiply-adds): a
    search may value states one flush at a time, at a few microseconds each,
    with no per-call overhead. It differs from BatchedQ's by float32 rounding
    only, at most ~3e-5 on the restaurant (tests/planning/test_bn_kernel.py).
    Segments whose valid values number fewer than two add exactly 0 (A - A),
    so only the others are computed, and only the live heads they need. As a
    value is a function of its arguments, the values computed are kept (the
    memo) for the searches that follow: consecutive tasks of a sequence revisit
    many states (a fifth to a quarter of them on the restaurant).
    """

    def __init__(self, batched: "BatchedQ", lib, memo: bool = True):
        """`memo`: keep every value computed (q_max per (state, task), V_AP per state) for later calls, up to
        2**MEMO_LOG2 / 2 entries (then it starts over): exact, as a value depends on its arguments alone."""
        import ctypes

        b, enc, net = batched, batched.enc, batched._net
        model = enc.model
        g = lambda t: t.detach().numpy().astype(np.float64)
        f32 = lambda a: np.ascontiguousarray(a, dtype=np.float32)
        f64 = lambda a: np.ascontiguousarray(a, dtype=np.float64)
        i32 = lambda a: np.ascontiguousarray(a, dtype=np.int32)
        lin = [m for m in net.encoder if isinstance(m, nn.Linear)]
        n, H, hid = enc.n_atoms, b.H, b.hid
        W = self.W = max(1, -(-n // 64))
        words = lambda masks: np.frombuffer(b"".join(int(m).to_bytes(8 * W, "little") for m in masks) or
                                            bytes(8 * W), dtype="<u8").copy()
        w1 = g(lin[0].weight).T
        ws, bs = g(net.from_state.weight).T, g(net.from_state.bias)
        cols = [(s, d, v) for s, (d, p, vals) in enumerate(b.segs) for v in vals.tolist()]
        var_cols = [np.flatnonzero(row).tolist() for row in b.s_var]
        groups = model.trigger_groups()             # variant -> one of its positive atoms (-1: none)
        tasks = list(model.tasks)
        goal0, goaln, gpos, gneg = [], [], [], []
        for t in tasks:
            goal0.append(len(gpos))
            goaln.append(len(t.bindings))
            gpos += [o.pos for o in t.bindings]
            gneg += [o.neg for o in t.bindings]
        self.arrays = a = {
            "w1": f32(w1[:n]), "b1t": f32(g(lin[0].bias)[None] + b.task_part),
            "w2": f32(g(lin[1].weight).T), "b2": f32(g(lin[1].bias)),
            "wv1": f32(ws[:, :H]), "bv1": f64(bs[:H]), "wv": f64(g(net.value.weight)[0]),
            "wh": f32(np.stack([ws[:, (1 + d) * H:(2 + d) * H] for d in b.live]) if b.live else np.zeros(1)),
            "bh": f32(np.stack([bs[(1 + d) * H:(2 + d) * H] for d in b.live]) if b.live else np.zeros(1)),
            "seg_head": i32(b.seg_head if len(b.segs) else np.zeros(1)),
            "seg_pref": f32(b.seg_pref[:, :H] if len(b.segs) else np.zeros(1)),
            "col_seg": i32([s for s, _, _ in cols] or [0]),
            "col_w": f32(np.stack([g(net.out[d].weight)[v] for _, d, v in cols]) if cols else np.zeros(1)),
            "col_b": f32([g(net.out[d].bias)[v] for _, d, v in cols] or [0.0]),
            "var_pos": words([o.pos for o in model.ops]), "var_neg": words([o.neg for o in model.ops]),
            "trig0": i32(np.cumsum([0] + [len(groups.get(i, [])) for i in range(n)])),
            "trig_var": i32(sum((list(groups.get(i, [])) for i in range(n)), []) or [0]),
            "always": i32(groups.get(-1, []) or [0]),
            "var_col0": i32(np.cumsum([0] + [len(c) for c in var_cols])[:-1]),
            "var_coln": i32([len(c) for c in var_cols]), "var_cols": i32(sum(var_cols, []) or [0]),
            "goal0": i32(goal0), "goaln": i32(goaln), "goal_pos": words(gpos), "goal_neg": words(gneg)}
        P, I = ctypes.c_void_p, ctypes.c_int64

        class Spec(ctypes.Structure):
            _fields_ = ([(k, I) for k in ("W", "n_atoms", "hid", "H", "n_live", "n_seg", "n_col", "n_var",
                                         "n_tasks")]
                        + [(k, P) for k in ("w1", "b1t", "w2", "b2", "wv1", "bv1", "wv")] + [("bv", ctypes.c_double)]
                        + [(k, P) for k in ("wh", "bh", "seg_head", "seg_pref", "col_seg", "col_w", "col_b",
                                            "var_pos", "var_neg", "trig0", "trig_var", "always")]
                        + [("n_always", I)]
                        + [(k, P) for k in ("var_col0", "var_coln", "var_cols", "goal0", "goaln", "goal_pos",
                                            "goal_neg", "memo")])

        self.spec = Spec(W=W, n_atoms=n, hid=hid, H=H, n_live=len(b.live), n_seg=len(b.segs), n_col=len(cols),
                         n_var=len(model.ops), n_tasks=len(tasks), bv=float(g(net.value.bias)[0]),
                         n_always=len(groups.get(-1, [])), **{k: v.ctypes.data for k, v in a.items()})
        self.lib, self.ctx, self.model = lib, ctypes.addressof(self.spec), model
        self.spec.memo = self._memo = lib.qnet_memo_new(W, MEMO_LOG2) if memo else None
        self.fn = ctypes.cast(lib.qnet_q_max, ctypes.c_void_p).value     # the search's bn_native_fn
        self.support = i32(enc.support)
        self.prob = f64(enc.task_prob[enc.support])

    def __del__(self):
        if getattr(self, "_memo", None):
            self.lib.qnet_memo_free(self._memo)
            self._memo = None

    def memo_stats(self) -> dict:
        """Entries held, hits and misses of the memo so far."""
        import ctypes

        out = (ctypes.c_int64 * 3)()
        self.lib.qnet_memo_stats(self._memo, out)
        return {"entries": out[0], "hits": out[1], "misses": out[2]}

    def words(self, states) -> np.ndarray:
        W = self.W
        return np.frombuffer(b"".join(s.to_bytes(8 * W, "little") for s in states) or bytes(8 * W), dtype="<u8")

    def q_max(self, states, task: int) -> np.ndarray:
        """max_a Q(s, task, a) per int state (a task index)."""
        out, words = np.zeros(len(states)), self.words(states)      # kept alive through the call
        if len(states) and self.lib.qnet_q_max(self.ctx, int(task), words.ctypes.data, len(states),
                                                self.W, out.ctypes.data):
            raise MemoryError("qnet_q_max failed")
        return out

    def v_ap(self, states) -> np.ndarray:
        """Σ_τ P(τ) max_a Q(s, τ, a) over the task support, per int state."""
        out, words = np.zeros(len(states)), self.words(states)
        if len(states) and self.lib.qnet_v_ap(self.ctx, words.ctypes.data, len(states), self.W,
                                               self.support.ctypes.data, self.prob.ctypes.data, len(self.support),
                                               out.ctypes.data):
            raise MemoryError("qnet_v_ap failed")
        return out


_QNET_LIB = None
MEMO_LOG2 = 20                     # the memo's slots (32 bytes each in the restaurant): 2**20, half of them used at most


def _qnet_lib():
    """The compiled learning/_qnet.c (planning.search.native), or None (no compiler, or QNET_NATIVE=0)."""
    global _QNET_LIB
    if _QNET_LIB is None:
        import ctypes

        from planning.search import native

        so = native.load(Path(__file__).with_name("_qnet.c"), "QNET_NATIVE")
        if so is not None:
            P, I = ctypes.c_void_p, ctypes.c_int64
            so.qnet_q_max.restype = ctypes.c_int
            so.qnet_q_max.argtypes = [P, I, P, I, I, P]
            so.qnet_v_ap.restype = ctypes.c_int
            so.qnet_v_ap.argtypes = [P, P, I, I, P, P, I, P]
            so.qnet_memo_new.restype = P
            so.qnet_memo_new.argtypes = [I, I]
            so.qnet_memo_free.argtypes = [P]
            so.qnet_memo_stats.argtypes = [P, P]
        _QNET_LIB = so or False
    return _QNET_LIB or None


class ValueFunction:
    """A trained Q-network bound to a layout's encoding: greedy actions, q_max and v_ap, batched.

    Inference runs on numpy snapshots of the weights taken at construction:
    `NumpyQ` for every action's Q (q_values, greedy), `BatchedQ` for the maxima
    the searches ask for (q_max, v_ap); `native_q_max` hands the Bellman–Novelty
    search the compiled q_max (`NativeQ`), built on first use.
    """

    def __init__(self, net: FactoredQNet, enc: Encoding, gamma: float = 0.97):
        """`gamma`: the discount the network was trained with (the search discounts its prefix costs by it)."""
        self.net, self.enc, self.gamma = net, enc, gamma
        self.fast = NumpyQ(net)
        self.batched = BatchedQ(net, enc)
        self._native, self.memo = None, True

    @classmethod
    def load(cls, path, model) -> "ValueFunction":
        """The value registry's hook (`learning.values`): the value of a learning.dqn checkpoint."""
        if path is None:
            raise DomainError("--value", "q-network needs a checkpoint: q-network:PATH")
        return load_value_function(path, model)

    @staticmethod
    def record(path) -> dict:
        """What a results file records of the checkpoint (`learning.greedy.checkpoint_config`)."""
        from learning.greedy import checkpoint_config

        return checkpoint_config(path)

    @property
    def native(self) -> "NativeQ | None":
        """The compiled engine, or None where there is no C compiler (or QNET_NATIVE=0)."""
        if self._native is None:
            lib = _qnet_lib()
            self._native = NativeQ(self.batched, lib, self.memo) if lib is not None else False
        return self._native or None

    def set_memo(self, on: bool) -> None:
        """Keep the compiled engine's values across calls (the default) or not (a fresh engine either way)."""
        self.memo, self._native = bool(on), None

    def native_q_max(self, task):
        """For `planning.search.bellman_novelty`: an object whose `fn` and `ctx` are the compiled q_max of
        this network (`bn_native_fn` of planning/search/_bn.c, task = task.index), or None."""
        return self.native

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
        return self.batched.q_max(states, _task_index(task))

    def v_ap(self, states) -> np.ndarray:
        """V_AP(s) = Σ_τ P(τ) max_a Q(s, τ, a) per state: the preparedness value (Eq. 3.8)."""
        return self.batched.v_ap(states)


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
    """Validity (and its head-mask bits) and target-network values of the boundary pairs, per completion
    state, valid until the next target sync.

    The anticipatory target needs Q_target(s', τ', ·) for every task of the support
    at every replayed completion state s'. The target network only changes at a
    sync, and a completion state is replayed several times between syncs (demos
    most of all), so those rows are computed once per sync; the online argmax is
    recomputed every update, so the Double-DQN target stays exact. Clear it
    whenever the target network changes.
    """

    def __init__(self, max_states: int = 4096):   # ~14 KB a state (two-room)
        self.max_states, self.entries = max_states, {}

    def __len__(self) -> int:
        return len(self.entries)

    def clear(self) -> None:
        """Forget every entry (call at each target sync)."""
        self.entries.clear()


def _support_valid(enc: Encoding, packed: np.ndarray) -> np.ndarray:
    """(n * support, actions) validity of every (state, task of the support) pair, state-major."""
    app = enc.applicable(packed)
    sat = enc.satisfied_all(packed)[:, enc.support]
    return enc.valid(np.repeat(app, len(enc.support), axis=0), sat.reshape(-1))


class SlotCache:
    """Per replay slot (`learning.replay.mixed_batch`'s "slots"): the encodings of its (s, τ) and
    (s', τ) rows (bits, validity and, given the network's `mask_bits`, its head masks), kept while
    the slot holds the same transition, and the target network's values at (s', τ), kept until
    the next target sync.

    A transition is replayed about a hundred times while it is in the agent's memory (102
    draws a step from 50,000) and a demonstration thousands of times, so almost every row's
    features and validity come from here, and the target values of the continuing rows drawn
    twice or more between two syncs. Call `sync` whenever the target network changes.
    """

    def __init__(self, enc: Encoding, size: int, mask_bits=None):
        self.enc, self.epoch, self.mask_bits = enc, 0, mask_bits
        self.writes = np.full(size, -1, dtype=np.int64)                 # the slot's write count when encoded
        self.bits = np.zeros((size, 2, enc.n_atoms), dtype=np.uint8)     # s, s'
        self.valid = np.zeros((size, 2, enc.n_actions), dtype=bool)      # (s, τ), (s', τ)
        self.q_epoch = np.full(size, -1, dtype=np.int64)
        self.q = np.zeros((size, 0), dtype=np.float32)                  # target values at (s', τ)
        self.masks = None

    def sync(self) -> None:
        """Forget the target values (the target network changed); the encodings stay."""
        self.epoch += 1

    def encode(self, batch: dict) -> np.ndarray:
        """Encode the batch's slots that are new or rewritten since; returns the batch's slots."""
        slots, writes = batch["slots"], batch["writes"]
        stale = np.flatnonzero(self.writes[slots] != writes)
        if len(stale):
            u, first = np.unique(slots[stale], return_index=True)
            rows = stale[first]
            both = np.concatenate([batch["states"][rows], batch["next_states"][rows]])
            bits = self.enc.bm.to_bits(both)
            valid = self.enc.valid_for(both, np.tile(batch["tasks"][rows], 2))
            m = len(rows)
            self.bits[u, 0], self.bits[u, 1] = bits[:m], bits[m:]
            self.valid[u, 0], self.valid[u, 1] = valid[:m], valid[m:]
            if self.mask_bits is not None:
                mb = self.mask_bits(valid)
                if self.masks is None:
                    self.masks = np.zeros((len(self.writes), 2, mb.shape[1]), dtype=bool)
                self.masks[u, 0], self.masks[u, 1] = mb[:m], mb[m:]
            self.writes[u] = writes[rows]
            self.q_epoch[u] = -1
        return slots

    def observe(self, batch: dict) -> tuple:
        """(observations, validity, head-mask bits or None) of the batch's (s, τ) rows, as
        `Encoding.observe` / `valid_for` / `FactoredQNet.mask_bits`."""
        slots = self.encode(batch)
        obs = np.concatenate([self.bits[slots, 0].astype(np.float32),
                              self.enc.task_feat[np.asarray(batch["tasks"], dtype=np.int64)]], axis=1)
        return obs, self.valid[slots, 0], None if self.masks is None else self.masks[slots, 0]

    def known(self, slots: np.ndarray) -> np.ndarray:
        """Which of these slots have target values from the current target network."""
        return self.q_epoch[slots] == self.epoch

    def store(self, slots: np.ndarray, q: np.ndarray) -> None:
        """Keep the target values of these slots until the next sync."""
        if self.q.shape[1] != q.shape[1]:
            self.q = np.zeros((len(self.q_epoch), q.shape[1]), dtype=np.float32)
            self.q_epoch[:] = -1
        self.q[slots] = q
        self.q_epoch[slots] = self.epoch


def _bits(enc: Encoding, packed: np.ndarray) -> np.ndarray:
    """(N, atoms) uint8 atom bits of packed states (none for none)."""
    return enc.bm.to_bits(packed) if len(packed) else np.zeros((0, enc.n_atoms), dtype=np.uint8)


class _Pairs:
    """(state, task) rows given as packed-state bits and indices: what td_targets feeds the networks.

    A FactoredQNet is evaluated per factored label (`q_labels`) and any other network per
    action; `best` and `values` answer in that network's columns (`columns`).
    """

    def __init__(self, enc: Encoding, bits: np.ndarray, state_of: np.ndarray, task_of: np.ndarray,
                 valid: np.ndarray):
        self.enc, self.bits, self.state_of, self.task_of, self.valid = enc, bits, state_of, task_of, valid
        self.feat = torch.from_numpy(enc.task_feat)

    def _inputs(self, rows):
        """The distinct states' bits of these rows and the rows' state and task indices into them."""
        states, s = np.unique(self.state_of[rows], return_inverse=True)
        return torch.from_numpy(self.bits[states]), self.feat, torch.from_numpy(s.reshape(-1)), torch.from_numpy(self.task_of[rows])

    @staticmethod
    def columns(net: nn.Module, n_actions: int) -> torch.Tensor:
        """The column of each action in `values`: its label's for a FactoredQNet, its own otherwise."""
        return net.lab_of_act if hasattr(net, "q_labels") else torch.arange(n_actions)

    def best(self, net: nn.Module, rows: np.ndarray, masks) -> torch.Tensor:
        """The column (`columns`) of the argmax over the valid actions of net's Q at the given rows (a
        FactoredQNet's over the labels that have a valid action)."""
        bits, feat, s, t = self._inputs(rows)
        if hasattr(net, "q_labels"):
            q = net.q_labels(net.first_layer_pairs(bits, feat, s, t), masks)
            return q.masked_fill(torch.from_numpy(~net.label_valid(self.valid[rows])), float("-inf")).max(dim=1)[1]
        valid = torch.from_numpy(self.valid[rows])
        return masked_max(net(torch.cat([bits[s], feat[t]], 1), valid), valid)[1]

    def values(self, net: nn.Module, rows: np.ndarray, masks) -> torch.Tensor:
        """net's Q at the given rows, in its columns (`columns`)."""
        bits, feat, s, t = self._inputs(rows)
        if hasattr(net, "q_labels"):
            return net.q_labels(net.first_layer_pairs(bits, feat, s, t), masks)
        return net(torch.cat([bits[s], feat[t]], 1), torch.from_numpy(self.valid[rows]))


def td_targets(online: nn.Module, target: nn.Module, enc: Encoding, batch: dict, gamma: float,
               horizon: str, cache: BoundaryCache | None = None, slots: SlotCache | None = None) -> torch.Tensor:
    """Double-DQN targets of Algorithm 1 (lines 11-17) for a batch of stored transitions.

    batch: next_states (N, W) uint64, tasks (N,), rewards (N,), kinds (N,) (CONTINUE /
    COMPLETE / TERMINAL). The online net picks, the target net values. The
    same-task pairs and the boundary pairs (every distinct completion state s' with
    every task of the support) go through each network in one batched call, with the
    first layer's state part once per state; a pair with one valid action (AUTO of a
    task that holds) has that action as its argmax without the online net; with a
    cache, the target net sees only the boundary states it has not valued since the
    last sync; with a slot cache (and the batch's "slots"), the continuing rows'
    encodings come from it and the target net sees only the slots it has not valued.
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
    tasks = np.asarray(batch["tasks"])[cont].astype(np.int64)
    n, k, A = len(cont), len(enc.support), enc.n_actions
    factored = hasattr(online, "mask_bits") and hasattr(target, "q_labels")
    masks_of = online.mask_bits if factored else (lambda v: None)
    if slots is not None and "slots" in batch:
        sl = slots.encode(batch)[cont]
        valid_c, bits_c, known = slots.valid[sl, 1], slots.bits[sl, 1], slots.known(sl)
        mb_c = slots.masks[sl, 1] if factored and slots.masks is not None else masks_of(valid_c)
    else:
        sl, known = None, np.zeros(n, dtype=bool)
        valid_c, bits_c = enc.valid_for(nxt[cont], tasks), _bits(enc, nxt[cont])
        mb_c = masks_of(valid_c)
    unknown = np.flatnonzero(~known)                                    # continuing rows the target must value
    # the distinct completion states, their cached entries and the ones to value afresh
    first: dict = {}
    inv = np.array([first.setdefault(s.tobytes(), len(first)) for s in nxt[comp]], dtype=np.int64)
    keys = list(first)
    uniq = nxt[comp][np.unique(inv, return_index=True)[1]]
    U = len(uniq)
    hit = [cache.entries.get(key) if cache is not None else None for key in keys]
    miss = np.array([j for j, e in enumerate(hit) if e is None], dtype=np.int64)
    valid_b = np.empty((U, k, A), dtype=bool)
    mb_b = np.empty((U, k, mb_c.shape[1]), dtype=bool) if factored else None
    if len(miss):
        valid_b[miss] = _support_valid(enc, uniq[miss]).reshape(len(miss), k, A)
        if factored:
            mb_b[miss] = masks_of(valid_b[miss].reshape(-1, A)).reshape(len(miss), k, -1)
    for j, e in enumerate(hit):
        if e is not None:
            valid_b[j] = e[0]
            if factored:
                mb_b[j] = e[2]
    # rows: the continuing (s', τ), then each completion state with every task of the support
    valid = np.concatenate([valid_c, valid_b.reshape(U * k, A)])
    pairs = _Pairs(enc, np.concatenate([bits_c, _bits(enc, uniq)]).astype(np.float32),
                   np.concatenate([np.arange(n), n + np.repeat(np.arange(U), k)]).astype(np.int64),
                   np.concatenate([tasks, np.tile(enc.support, U)]).astype(np.int64), valid)
    several = np.flatnonzero(valid.sum(1) > 1)                          # rows whose argmax needs the online net
    rows_t = np.concatenate([unknown, (n + miss[:, None] * k + np.arange(k)).reshape(-1)]).astype(np.int64)
    nu = len(unknown)
    with torch.inference_mode():
        masks = online.masks_from_bits(np.concatenate([mb_c, mb_b.reshape(U * k, mb_c.shape[1])])) if factored else None
        pick = lambda rows: None if masks is None else FactoredQNet.select_masks(masks, torch.from_numpy(rows))
        col = _Pairs.columns(target, A)
        best = col[torch.from_numpy(valid.argmax(1))]                   # the one valid action, where one
        if len(several):
            best[torch.from_numpy(several)] = pairs.best(online, several, pick(several))
        qt = pairs.values(target, rows_t, pick(rows_t))
        picked = torch.empty(len(valid), dtype=torch.float32)
        rt = torch.from_numpy(rows_t)
        picked[rt] = qt.gather(1, best[rt][:, None])[:, 0]
        if sl is not None:                    # the slots' target values, kept and reused
            kn = np.flatnonzero(known)
            if len(kn):
                picked[torch.from_numpy(kn)] = torch.from_numpy(slots.q[sl[kn], best[torch.from_numpy(kn)].numpy()])
            if nu:
                slots.store(sl[unknown], qt[:nu].numpy())
        held = [j for j, e in enumerate(hit) if e is not None]
        if held:                              # the cached target values at the online argmax
            cols = best.numpy()[n:].reshape(U, k)[held]
            qh = np.stack([hit[j][1] for j in held])
            rows_h = torch.from_numpy((n + np.array(held)[:, None] * k + np.arange(k)).reshape(-1))
            picked[rows_h] = torch.from_numpy(np.take_along_axis(qh, cols[:, :, None], 2).reshape(-1))
        if cache is not None:
            qt = qt.numpy()
            for i, j in enumerate(miss[:max(0, cache.max_states - len(cache.entries))]):
                cache.entries[keys[j]] = (valid_b[j].copy(), qt[nu + i * k:nu + (i + 1) * k].copy(),
                                          None if mb_b is None else mb_b[j].copy())
    y[torch.from_numpy(cont)] += gamma * picked[:n]
    if len(comp):
        p = torch.from_numpy(enc.task_prob[enc.support]).float()
        y[torch.from_numpy(comp)] += gamma * (picked[n:].reshape(U, k) @ p)[torch.from_numpy(inv)]
    return y


# ---- checkpoints ---------------------------------------------------------
DOMAIN_KEYS = ("domain", "domain_sha256", "domain_files")
"""What a checkpoint records of the domain it was trained on (`planning.domain.identity`)."""
_warned: set = set()


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
    return full_precision(from_plain(payload), "net")


def network_payload(net: FactoredQNet, enc: Encoding, extra: dict | None = None) -> dict:
    """The minimal checkpoint of a network: weights, sizes, the layout signature and the domain it was
    trained on (its PDDL name and the digest of its files, `planning.domain.identity`)."""
    from planning.domain.identity import identity

    return {"net": net.state_dict(), "dims": net.dims, "signature": enc.signature(), **identity(enc.model),
            **(extra or {})}


def check_domain(path, payload: dict, model) -> None:
    """A checkpoint about to be used on `model`'s layout: one recorded for another domain (its PDDL name)
    or another layout is a one-line DomainError; one trained on other content of this domain (its
    recorded domain_sha256 differs: an edited cost, a retuned reward) is a one-line warning on stderr,
    once per file, and stays usable. A checkpoint that records no domain (those written before
    2026-12, the committed ones among them) is checked by its layout signature alone."""
    import sys

    from planning.domain.identity import mismatch

    sig = payload.get("signature") or {}
    name = payload.get("domain") or sig.get("domain")
    layout = (payload.get("config") or {}).get("layout") or sig.get("layout")
    if (name or model.name, layout or model.layout) != (model.name, model.layout):
        raise DomainError(path, f"trained for {name}/{layout}, not {model.name}/{model.layout}")
    diff = mismatch(payload, model) if payload.get("domain_sha256") is not None else None
    key = (str(Path(path).resolve()) if isinstance(path, (str, Path)) else str(path), payload.get("domain_sha256"))
    if diff is not None and key not in _warned:
        _warned.add(key)
        print(f"warning: {path}: trained on {diff}; used as it is", file=sys.stderr)


def build_network(enc: Encoding, hidden: int = 256, embed: int = 16, head_hidden: int = 64) -> FactoredQNet:
    """A fresh network for a layout's encoding."""
    return FactoredQNet(enc.obs_dim, enc.labels, [len(v) for v in enc.vocab], hidden, embed, head_hidden)


def load_value_function(path, model) -> ValueFunction:
    """The greedy value of a checkpoint, checked against the layout it is used on."""
    return value_function(read_checkpoint(path), model, path)


def value_function(payload: dict, model, path="checkpoint") -> ValueFunction:
    """The greedy value of a loaded checkpoint payload (float32 weights), checked against the layout and
    the domain (`check_domain`); `path` names it in errors."""
    check_domain(path, payload, model)
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

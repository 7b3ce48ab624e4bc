"""The Bellman targets of the DQN update (Algorithm 1, lines 11-17) and the caches that make them cheap.

`td_targets` computes the Double-DQN targets of a minibatch: the online network picks,
the target network values, the boundary rows (a completion state with every task of the
support) weighted by P(τ). `BoundaryCache` keeps the boundary rows' target values and
`SlotCache` the replay slots' encodings and target values until the next target sync.
`preparedness` is V_AP under a pair of networks (with online = target: the greedy V_AP).
"""

from __future__ import annotations

import numpy as np
import torch
from torch import nn

from learning.encoding import Encoding
from planning.errors import DomainError

from .network import FactoredQNet, masked_max, object_pairs
from .replay import COMPLETE, CONTINUE


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
    dev = _device(online)
    obs, valid = torch.from_numpy(obs).to(dev), torch.from_numpy(valid).to(dev)
    with torch.no_grad():
        _, best = masked_max(online(obs, valid), valid)
        qt = target(obs, valid) if target is not online else online(obs, valid)
        v = qt.gather(1, best[:, None])[:, 0].reshape(len(packed), len(enc.support)).double().cpu()
    return (v @ torch.from_numpy(enc.task_prob[enc.support])).numpy()


def _device(net: nn.Module) -> torch.device:
    """Where a network's weights are (its inputs go there; its answers come back to the CPU); the CPU for a
    network without parameters."""
    p = next(net.parameters(), None)
    return torch.device("cpu") if p is None else p.device


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

    def __init__(self, max_states: int = 4096):  # ~14 KB a state (two-room)
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
    """Per replay slot (`learning.q.replay.mixed_batch`'s "slots"): the encodings of its (s, τ) and
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
        self.writes = np.full(size, -1, dtype=np.int64)  # the slot's write count when encoded
        self.bits = np.zeros((size, 2, enc.n_atoms), dtype=np.uint8)  # s, s'
        self.valid = np.zeros((size, 2, enc.n_actions), dtype=bool)  # (s, τ), (s', τ)
        self.q_epoch = np.full(size, -1, dtype=np.int64)
        self.q = np.zeros((size, 0), dtype=np.float32)  # target values at (s', τ)
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
        obs = self.enc.observe_bits(self.bits[slots, 0], batch["tasks"])
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

    def __init__(self, enc: Encoding, bits: np.ndarray, state_of: np.ndarray, task_of: np.ndarray, valid: np.ndarray):
        self.enc, self.bits, self.state_of, self.task_of, self.valid = enc, bits, state_of, task_of, valid
        self.feat = torch.from_numpy(enc.task_feat)
        self.objects = torch.from_numpy(enc.object_map) if enc.paired else None

    def _inputs(self, rows, device):
        """The distinct states' bits of these rows, the task encodings, the rows' state and task indices into
        them and the goal-object map (None without one), on the network's device."""
        states, s = np.unique(self.state_of[rows], return_inverse=True)
        return (
            torch.from_numpy(self.bits[states]).to(device),
            self.feat.to(device),
            torch.from_numpy(s.reshape(-1)).to(device),
            torch.from_numpy(self.task_of[rows]).to(device),
            None if self.objects is None else self.objects.to(device),
        )

    def _observations(self, bits, feat, s, t, objects) -> torch.Tensor:
        """The rows' observations in full, for a network without the split first layer."""
        obs = [bits[s], feat[t]]
        if objects is not None:
            obs.append(object_pairs(bits, objects, s, t))
        return torch.cat(obs, 1)

    @staticmethod
    def columns(net: nn.Module, n_actions: int) -> torch.Tensor:
        """The column of each action in `values`: its label's for a FactoredQNet, its own otherwise."""
        return net.lab_of_act if hasattr(net, "q_labels") else torch.arange(n_actions)

    def best(self, net: nn.Module, rows: np.ndarray, masks) -> torch.Tensor:
        """The column (`columns`) of the argmax over the valid actions of net's Q at the given rows (a
        FactoredQNet's over the labels that have a valid action), on the CPU."""
        dev = _device(net)
        inputs = self._inputs(rows, dev)
        if hasattr(net, "q_labels"):
            q = net.q_labels(net.first_layer_pairs(*inputs), masks)
            invalid = torch.from_numpy(~net.label_valid(self.valid[rows])).to(dev)
            return q.masked_fill(invalid, float("-inf")).max(dim=1)[1].cpu()
        valid = torch.from_numpy(self.valid[rows]).to(dev)
        return masked_max(net(self._observations(*inputs), valid), valid)[1].cpu()

    def values(self, net: nn.Module, rows: np.ndarray, masks) -> torch.Tensor:
        """net's Q at the given rows, in its columns (`columns`), on the CPU."""
        dev = _device(net)
        inputs = self._inputs(rows, dev)
        if hasattr(net, "q_labels"):
            return net.q_labels(net.first_layer_pairs(*inputs), masks).cpu()
        return net(self._observations(*inputs), torch.from_numpy(self.valid[rows]).to(dev)).cpu()


class TargetPlan:
    """One minibatch's Double-DQN targets (Algorithm 1, lines 11-17) in three parts: this constructor does
    the numpy work (which rows each network values, their validity and head masks, the cached values),
    `online_rows` / `target_rows` name the two network evaluations, and `finish` turns their answers
    into the targets. `td_targets` runs the three for one network pair; a trainer of several seeds
    (`learning.q.seeds`) runs the two evaluations of every seed's plan as one batched call each.

    batch: next_states (N, W) uint64, tasks (N,), rewards (N,), kinds (N,) (CONTINUE /
    COMPLETE / TERMINAL). The online net picks, the target net values. The
    same-task pairs and the boundary pairs (every distinct completion state s' with
    every task of the support) go through each network in one batched call, with the
    first layer's state part once per state; a pair with one valid action (AUTO of a
    task that holds) has that action as its argmax without the online net; with a
    cache, the target net sees only the boundary states it has not valued since the
    last sync; with a slot cache (and the batch's "slots"), the continuing rows'
    encodings come from it and the target net sees only the slots it has not valued. The
    boundary rows are weighted by the layout's P(τ') (the thesis's), or with an estimator
    (`planning.world.estimators`) by its P(τ' | the task the transition completed).
    """

    def __init__(
        self,
        online: nn.Module,
        target: nn.Module,
        enc: Encoding,
        batch: dict,
        gamma: float,
        horizon: str,
        cache: BoundaryCache | None = None,
        slots: SlotCache | None = None,
        estimator=None,
    ):
        if horizon not in ("myopic", "anticipatory"):
            raise DomainError("--horizon", f"'{horizon}' is neither myopic nor anticipatory")
        self.gamma, self.enc, self.cache, self.slots = gamma, enc, cache, slots
        known = estimator is None or estimator.name == "known"
        self.estimator = None if known else estimator  # None: the layout's P, as in the thesis
        self.y = torch.as_tensor(batch["rewards"], dtype=torch.float32).clone()
        kinds = np.asarray(batch["kinds"])
        nxt = batch["next_states"]
        self.cont = cont = np.flatnonzero(kinds == CONTINUE)
        self.comp = comp = np.flatnonzero(kinds == COMPLETE) if horizon == "anticipatory" else cont[:0]
        self.empty = not len(cont) and not len(comp)
        if self.empty:
            return
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
        unknown = np.flatnonzero(~known)  # continuing rows the target must value
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
        self.pairs = _Pairs(
            enc,
            np.concatenate([bits_c, _bits(enc, uniq)]).astype(np.float32),
            np.concatenate([np.arange(n), n + np.repeat(np.arange(U), k)]).astype(np.int64),
            np.concatenate([tasks, np.tile(enc.support, U)]).astype(np.int64),
            valid,
        )
        self.online_rows = np.flatnonzero(valid.sum(1) > 1)  # rows whose argmax needs the online net
        self.target_rows = np.concatenate([unknown, (n + miss[:, None] * k + np.arange(k)).reshape(-1)]).astype(
            np.int64
        )
        with torch.inference_mode():
            self.masks = (
                online.masks_from_bits(np.concatenate([mb_c, mb_b.reshape(U * k, mb_c.shape[1])])) if factored else None
            )
            self.columns = _Pairs.columns(target, A).cpu()
        self.n, self.k, self.U, self.inv, self.keys, self.hit, self.miss = n, k, U, inv, keys, hit, miss
        self.comp_tasks = np.asarray(batch["tasks"])[comp]
        self.sl, self.known, self.unknown, self.valid_b, self.mb_b = sl, known, unknown, valid_b, mb_b

    def masks_at(self, rows: np.ndarray):
        """The head masks of some rows (None for a network that is not factored)."""
        if self.masks is None:
            return None
        return FactoredQNet.select_masks(self.masks, torch.from_numpy(rows).to(self.masks[0].device))

    def finish(self, best_online: torch.Tensor | None, qt: torch.Tensor) -> torch.Tensor:
        """The targets, from the online net's argmax column at `online_rows` (None where there are none)
        and the target net's Q at `target_rows` (its columns, `_Pairs.columns`)."""
        if self.empty:
            return self.y
        n, k, U, cache, slots, sl = self.n, self.k, self.U, self.cache, self.slots, self.sl
        with torch.inference_mode():
            best = self.columns[torch.from_numpy(self.pairs.valid.argmax(1))]  # the one valid action, where one
            if best_online is not None:
                best[torch.from_numpy(self.online_rows)] = best_online
            picked = torch.empty(len(self.pairs.valid), dtype=torch.float32)
            rt = torch.from_numpy(self.target_rows)
            picked[rt] = qt.gather(1, best[rt][:, None])[:, 0]
            nu = len(self.unknown)
            if sl is not None:  # the slots' target values, kept and reused
                kn = np.flatnonzero(self.known)
                if len(kn):
                    picked[torch.from_numpy(kn)] = torch.from_numpy(slots.q[sl[kn], best[torch.from_numpy(kn)].numpy()])
                if nu:
                    slots.store(sl[self.unknown], qt[:nu].numpy())
            held = [j for j, e in enumerate(self.hit) if e is not None]
            if held:  # the cached target values at the online argmax
                cols = best.numpy()[n:].reshape(U, k)[held]
                qh = np.stack([self.hit[j][1] for j in held])
                rows_h = torch.from_numpy((n + np.array(held)[:, None] * k + np.arange(k)).reshape(-1))
                picked[rows_h] = torch.from_numpy(np.take_along_axis(qh, cols[:, :, None], 2).reshape(-1))
            if cache is not None:
                qt = qt.numpy()
                for i, j in enumerate(self.miss[: max(0, cache.max_states - len(cache.entries))]):
                    cache.entries[self.keys[j]] = (
                        self.valid_b[j].copy(),
                        qt[nu + i * k : nu + (i + 1) * k].copy(),
                        None if self.mb_b is None else self.mb_b[j].copy(),
                    )
        y = self.y
        y[torch.from_numpy(self.cont)] += self.gamma * picked[:n]
        if len(self.comp) and self.estimator is None:
            p = torch.from_numpy(self.enc.task_prob[self.enc.support]).float()
            y[torch.from_numpy(self.comp)] += self.gamma * (picked[n:].reshape(U, k) @ p)[torch.from_numpy(self.inv)]
        elif len(self.comp):  # P(τ' | the task completed), row by row, from the estimator
            tasks, sup = self.enc.model.tasks, self.enc.support
            rows = {t: self.estimator.probabilities(tasks[int(t)])[sup] for t in np.unique(self.comp_tasks)}
            p = torch.from_numpy(np.stack([rows[t] for t in self.comp_tasks])).float()
            v = picked[n:].reshape(U, k)[torch.from_numpy(self.inv)]
            y[torch.from_numpy(self.comp)] += self.gamma * (v * p).sum(1)
        return y


def td_targets(
    online: nn.Module,
    target: nn.Module,
    enc: Encoding,
    batch: dict,
    gamma: float,
    horizon: str,
    cache: BoundaryCache | None = None,
    slots: SlotCache | None = None,
    estimator=None,
) -> torch.Tensor:
    """Double-DQN targets of Algorithm 1 (lines 11-17) for a batch of stored transitions (`TargetPlan`
    says how): the online net picks, the target net values; the boundary's P(τ') from `estimator`
    (`planning.world.estimators`; None or known: the layout's P)."""
    plan = TargetPlan(online, target, enc, batch, gamma, horizon, cache, slots, estimator)
    if plan.empty:
        return plan.y
    with torch.inference_mode():
        rows = plan.online_rows
        best = plan.pairs.best(online, rows, plan.masks_at(rows)) if len(rows) else None
        qt = plan.pairs.values(target, plan.target_rows, plan.masks_at(plan.target_rows))
    return plan.finish(best, qt)

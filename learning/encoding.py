"""Observation and factored-action encodings derived from a compiled model (thesis §4.1.1, Appendix A.1).

Observation. The state's atom bits (`BatchedModel.to_bits`) followed by a task
encoding: a one-hot of the task type, then, for each argument position k, a
one-hot over the objects that appear at position k in some task instance plus
a *none* slot (the type takes fewer arguments). The thesis's 318/329-dim vector
(Appendix A.1) is a hand-made decoding of the same facts: agent location,
hand-free, held object, per-object location / dirty / contents / container /
kind, bread spread (each a one-hot of a group of atoms), then four task fields
(type, target location, target kind, target object) with none slots. Here the
atoms themselves are the features (70 two-room, 78 three-room), so no domain
knowledge enters Python; the kind fields are static facts and drop out.

With `task_features = "arguments+goal"` (domain.toml [training]; default "arguments", the
thesis's) the task encoding also carries the task's *goal atoms*: a multi-hot over the atoms
some binding of its goal requires true, then over those it requires false (columns no task
uses are dropped). A domain whose tasks name an entry of a library (a job object whose static
facts say which blocks go where, as the blockworld's) shows the learner nothing of the goal in
its arguments; the goal atoms line up with the state's own bits. On the blockworld a paired
check (myopic, seed 0, 20,000 steps) found no difference (docs/domains.md), so no bundled domain
uses it.

With `task_features = "arguments+objects"` the observation also carries the state *seen from the
goal's objects*: for each object every binding of the task's goal names (its slot: first, second,
... in atom order), the state's atoms that mention it, keyed by (slot, predicate, the object's
argument position, the other arguments). For the blockworld's `two-blocks(d_orange_e_green)` the
slots are d, orange, e, green, and the features say where d is, whether it is held, what stands
on orange, whether the robot is there, and the same for e and green: the join of "the job's block"
and "where blocks are" that the flat vector leaves the network to learn for each job apart. The
features depend on the state and the task together (`Encoding.paired`): the networks' split first
layer adds their term per (state, task) pair (`FactoredQNet.first_layer_pairs`). The blockworld
trains with it (its domain.toml says why); the restaurant keeps the thesis's encoding.

Actions. The factored labels of `planning.domain.factored` (Table A.1), plus one extra
pseudo-action AUTO = n_actions: the internal auto_complete event. A task that
already holds when it is drawn completes at zero cost with reward R_goal; AUTO
is then the *only* valid action (and never valid otherwise), so
V(s, τ) = max_a Q(s, τ, a) = Q(s, τ, AUTO) for a satisfied τ and the preparedness
value V_AP(s) = Σ_τ P(τ) max_a Q(s, τ, a) needs no special case. AUTO's label is
its own type value with every argument at *none*.
"""

from __future__ import annotations

import numpy as np

from planning.domain.batched import BatchedModel
from planning.domain.factored import factored_actions
from planning.errors import DomainError

AUTO_TYPE = "auto_complete"
TASK_FEATURES = ("arguments", "arguments+goal", "arguments+objects")
"""The task encodings (module docstring): the thesis's one-hots of type and arguments, those with the goal atoms,
and those with the state seen from the goal's objects."""


def domain_task_features(model) -> str:
    """The task encoding domain.toml [training] task_features names (default: arguments)."""
    value = model.config.get("training", {}).get("task_features", "arguments")
    if value not in TASK_FEATURES:
        raise DomainError(
            model.files["config"], f"[training] task_features {value!r} is not one of {', '.join(TASK_FEATURES)}"
        )
    return value


class Encoding:
    """Observation features, validity masks and the factored action table of one compiled layout."""

    def __init__(self, model, task_features: str | None = None):
        """`task_features`: one of TASK_FEATURES; None: the domain's (`domain_task_features`)."""
        self.model = model
        self.task_features = domain_task_features(model) if task_features is None else task_features
        if self.task_features not in TASK_FEATURES:
            raise DomainError("task_features", f"{self.task_features!r} is not one of {', '.join(TASK_FEATURES)}")
        self.bm = BatchedModel(model)
        self.factored = factored_actions(model)
        self.n_atoms = model.n_atoms
        self.n_words = self.bm.n_words
        self.n_actions = model.n_actions + 1  # ground actions, then AUTO
        self.AUTO = model.n_actions
        fa = self.factored
        self.heads = list(fa.heads)
        self.vocab = [list(fa.vocab[0]) + [AUTO_TYPE]] + [list(v) for v in fa.vocab[1:]]
        auto_row = [len(fa.vocab[0])] + [len(v) - 1 for v in fa.vocab[1:]]  # none for every argument
        self.labels = np.vstack([fa.labels, np.array([auto_row], dtype=np.int64)])
        self.action_type = self.labels[:, 0]
        self.type_names = self.vocab[0]
        self._task_features()
        self._task_goals()
        self._object_view()
        self.obs_dim = self.n_atoms + self.task_feat.shape[1] + self.object_map.shape[2]

    # ---- task encoding ---------------------------------------------------
    def _task_features(self) -> None:
        tasks = list(self.model.tasks)
        types = list(dict.fromkeys(t.type for t in tasks))
        arity = max((len(t.args) for t in tasks), default=0)
        slots = [list(dict.fromkeys(t.args[k] for t in tasks if len(t.args) > k)) for k in range(arity)]
        width = len(types) + sum(len(s) + 1 for s in slots)
        feat = np.zeros((len(tasks), width), dtype=np.float32)
        for i, t in enumerate(tasks):
            feat[i, types.index(t.type)] = 1.0
            off = len(types)
            for k, objs in enumerate(slots):
                feat[i, off + (objs.index(t.args[k]) if k < len(t.args) else len(objs))] = 1.0
                off += len(objs) + 1
        if self.task_features == "arguments+goal":
            feat = np.concatenate([feat, self._goal_atoms(tasks)], axis=1)
        self.task_types, self.task_feat = types, feat
        self.task_prob = np.asarray(self.model.tasks.probabilities, dtype=np.float64)
        self.task_prob = self.task_prob / self.task_prob.sum()
        self.support = np.flatnonzero(self.task_prob > 0)  # the tasks V_AP averages over

    def _goal_atoms(self, tasks) -> np.ndarray:
        """(tasks, k) multi-hot of the atoms some binding of each task's goal needs true, then false; the k
        columns are those some task uses, in atom order."""
        n = self.model.n_atoms
        hot = np.zeros((len(tasks), 2 * n), dtype=np.float32)
        for i, t in enumerate(tasks):
            pos = neg = 0
            for b in t.bindings:
                pos, neg = pos | b.pos, neg | b.neg
            hot[i, :n] = [(pos >> a) & 1 for a in range(n)]
            hot[i, n:] = [(neg >> a) & 1 for a in range(n)]
        return hot[:, hot.any(axis=0)]

    def _object_view(self) -> None:
        """object_map (tasks, atoms, k): which of the k goal-object features each state atom sets, per task
        (k = 0 unless task_features is arguments+objects)."""
        model, keys, hits = self.model, {}, []
        if self.task_features == "arguments+objects":
            mentions = {}  # object -> [(atom, argument position)]
            for i, atom in enumerate(model.atoms[: model.n_atoms]):
                for pos, obj in enumerate(atom[1:]):
                    mentions.setdefault(obj, []).append((i, pos))
            for t in model.tasks:
                named = None
                for b in t.bindings:
                    atoms = [model.atoms[i] for i in range(model.n_atoms) if (b.pos | b.neg) >> i & 1]
                    objs = list(dict.fromkeys(o for atom in atoms for o in atom[1:]))
                    named = objs if named is None else [o for o in named if o in objs]
                for slot, obj in enumerate(named or []):
                    for i, pos in mentions.get(obj, []):
                        atom = model.atoms[i]
                        key = (slot, atom[0], pos, atom[1:][:pos] + atom[1:][pos + 1 :])
                        hits.append((t.index, i, keys.setdefault(key, len(keys))))
        self.object_map = np.zeros((len(model.tasks), model.n_atoms, len(keys)), dtype=np.float32)
        for t, i, k in hits:
            self.object_map[t, i, k] = 1.0
        self.object_keys = list(keys)

    def object_features(self, bits: np.ndarray, tasks: np.ndarray) -> np.ndarray:
        """(N, k) float32 goal-object features of (state bits, task index) rows (`_object_view`)."""
        out = np.zeros((len(bits), self.object_map.shape[2]), dtype=np.float32)
        if out.shape[1]:
            for t in np.unique(tasks):
                rows = tasks == t
                out[rows] = bits[rows] @ self.object_map[t]
        return out

    def _task_goals(self) -> None:
        # Every binding of every task goal as packed masks, for batched satisfaction tests.
        pos, neg, owner = [], [], []
        for t in self.model.tasks:
            for b in t.bindings:
                pos.append(b.pos)
                neg.append(b.neg)
                owner.append(t.index)
        self.goal_pos = self.bm.pack(pos)
        self.goal_neg = self.bm.pack(neg)
        self.goal_owner = np.array(owner, dtype=np.int64)
        self.goal_of = np.zeros((len(owner), len(self.model.tasks)), dtype=np.float32)  # binding -> task
        self.goal_of[np.arange(len(owner)), self.goal_owner] = 1.0

    # ---- batched features ------------------------------------------------
    def pack(self, states) -> np.ndarray:
        """(N, W) uint64 packed states from int states (a packed array passes through)."""
        if isinstance(states, np.ndarray) and states.dtype == np.uint64:
            return states.reshape(-1, self.n_words)
        return self.bm.pack(list(states))

    def observe(self, packed: np.ndarray, tasks: np.ndarray) -> np.ndarray:
        """(N, obs_dim) float32 observations of (state, task index) pairs."""
        return self.observe_bits(self.bm.to_bits(packed), tasks)

    def observe_bits(self, bits: np.ndarray, tasks: np.ndarray) -> np.ndarray:
        """`observe` of states given as their (N, atoms) bits."""
        bits, tasks = bits.astype(np.float32), np.asarray(tasks, dtype=np.int64)
        return np.concatenate([bits, self.task_feat[tasks], self.object_features(bits, tasks)], axis=1)

    @property
    def paired(self) -> bool:
        """Whether the observation has features of the (state, task) pair (goal-object features), beyond the
        state's bits and the task's own encoding."""
        return self.object_map.shape[2] > 0

    def satisfied_all(self, packed: np.ndarray) -> np.ndarray:
        """(N, tasks) bool: which task goals hold in each state."""
        ok = np.ones((packed.shape[0], len(self.goal_owner)), dtype=bool)
        for w in range(self.n_words):
            s = packed[:, w, None]
            ok &= ((~s & self.goal_pos[None, :, w]) | (s & self.goal_neg[None, :, w])) == 0
        return (ok.astype(np.float32) @ self.goal_of) > 0  # some binding of the task's goal holds

    def applicable(self, packed: np.ndarray) -> np.ndarray:
        """(N, n_actions) bool: applicable ground actions, AUTO column False."""
        out = np.zeros((packed.shape[0], self.n_actions), dtype=bool)
        out[:, : self.AUTO] = self.bm.applicable(packed)
        return out

    def valid(self, applicable: np.ndarray, satisfied: np.ndarray) -> np.ndarray:
        """(N, n_actions) validity: the applicable actions, or AUTO alone where the task already holds."""
        out = applicable.copy()
        out[satisfied] = False
        out[satisfied, self.AUTO] = True
        return out

    def valid_for(self, packed: np.ndarray, tasks: np.ndarray) -> np.ndarray:
        """Validity masks of (state, task index) pairs."""
        tasks = np.asarray(tasks, dtype=np.int64)
        sat = self.satisfied_all(packed)[np.arange(len(tasks)), tasks]
        return self.valid(self.applicable(packed), sat)

    def signature(self) -> dict:
        """What a checkpoint must agree on to be used with this layout."""
        return {
            "domain": self.model.name,
            "layout": self.model.layout,
            "atoms": self.n_atoms,
            "actions": self.n_actions,
            "obs_dim": self.obs_dim,
            "tasks": len(self.model.tasks),
            "vocab": [len(v) for v in self.vocab],
            **({} if self.task_features == "arguments" else {"task_features": self.task_features}),
        }

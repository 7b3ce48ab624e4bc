"""Pattern databases: exact goal distances in projections of the model onto a few objects.

Delete-relaxation heuristics (h_max, LM-cut) let the robot be everywhere it
has been and carry everything at once, so they miss about half the cost of
fetching and carrying with one hand. A projection keeps exactly what they miss
for a few objects: the agent's own atoms (its position, a free hand: atoms
whose arguments are all locations), and every fluent atom of the chosen objects
(where each is, held or not, dirty, filled). Everything else is forgotten: a
precondition on a forgotten atom is dropped, and a conditional effect whose
condition mentions one may or may not fire. Every real transition maps to an
abstract one, so the exact goal distance in the projection, computed once by
Dijkstra backwards from the abstract goal states, is an admissible and
consistent heuristic (Culberson & Schaeffer 1998; Edelkamp 2001).

The patterns come from the task goals: each goal binding's objects, alone and
with each object that shares a ground action with them (a cup with the jar
that refills it, the water machine that fills it with coffee; a bowl and an
apple with the knife). A task's estimate is the smallest over its bindings of
the largest over that binding's patterns, or of the sum of per-object
projections under a cost partitioning where the goal names several objects. A
window of tasks (the clairvoyant's) gets projections onto its leading tasks'
goal objects and onto each task's own, with the stage in the abstract state:
the cost-to-go runs backwards from the last task through each task's goal and
consumption.

Locations are the objects the domain folder lists under its layout's rooms;
"objects" are the others that occur in a fluent atom some action, consumption
or world reset changes. Abstract state spaces are explored from the initial and
reset states by actions and task consumptions, so every state of the persistent
world is in them; a state outside (e.g. hand-written) gets h = 0.

Each projection's states and goal distances are kept in the user's cache folder
(planning.cache), named by a digest of what they are computed from: a later
process loads them instead of exploring (`PDB_CACHE=0` turns this off).
"""

from __future__ import annotations

import itertools
import time
from collections import OrderedDict
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from planning import cache
from planning.domain.batched import BatchedModel, satisfied
from planning.errors import DomainError
from planning.states import INF_64, StateTable, state_keys

CHUNK = 1 << 14  # abstract states expanded per numpy call
# What a cached space or distance table depends on besides its inputs: the code of this module, of the state
# keys and tables (states.py) and of the goal test (batched.py's `satisfied`).
_SOURCE = cache.digest(
    *(
        Path(__file__).parent.parent.joinpath(f).read_bytes()
        for f in ("heuristics/pdb.py", "states.py", "domain/batched.py")
    )
)
WINDOW_CACHE_BYTES = 1 << 31  # window distance tables kept for windows of tasks seen again


def _bits(mask: int) -> list[int]:
    return [i for i in range(mask.bit_length()) if mask >> i & 1]


def _changes(op) -> int:
    """The atoms an op may add or delete, its conditional effects' included."""
    out = op.add | op.dele
    for _, _, ca, cd in op.cond:
        out |= ca | cd
    return out


@dataclass
class _Ops:
    """Abstract operators as (V, W) word arrays; `edge` says whether it is an action (else consumption).
    Row v stands for the ground actions members[starts[v]:starts[v + 1]] (all projected alike); under
    a cost function, its cost is their cheapest (`row_costs`)."""

    pos: np.ndarray
    neg: np.ndarray
    add: np.ndarray
    keep: np.ndarray
    edge: np.ndarray
    members: np.ndarray
    starts: np.ndarray

    def row_costs(self, costs: np.ndarray) -> np.ndarray:
        """(V,) each row's cost under per-ground-action costs (consumption rows: 0)."""
        out = np.zeros(len(self.edge), dtype=np.int64)
        has = self.starts[1:] > self.starts[:-1]
        if has.any():
            out[has] = np.minimum.reduceat(costs[self.members], self.starts[:-1][has])
        return out


class Projection:
    """The model projected onto the agent's atoms and a set of objects: its reachable abstract states
    (sorted keys and rows) and its transition graph, labelled by operator, ready for goal
    distances under the model's action costs or any other (a cost partitioning's share)."""

    def __init__(
        self,
        model,
        bm: BatchedModel,
        objects: frozenset,
        atom_mask: int,
        seeds: np.ndarray,
        consumption: list,
        max_states: int,
        costs: list | None = None,
    ):
        """`costs`: per ground action, in place of the model's (a cost partitioning's share)."""
        self.objects = objects
        self.mask = bm.pack([atom_mask])[0]
        self._model, self._bm, self._atom_mask = model, bm, atom_mask
        self.costs = np.asarray(model.action_cost if costs is None else costs, dtype=np.int64)
        self._ops = ops = _project_ops(model, bm, atom_mask, consumption)
        seeds = seeds & self.mask
        self._compute_space = lambda: _space(bm, ops, seeds, max_states)
        self._key = cache.digest(_SOURCE, bm.n_words, max_states, ops.pos, ops.neg, ops.add, ops.keep, ops.edge, seeds)
        # The states are kept on disk, the edges (ten times their size) are explored again where needed.
        space = cache.arrays("pdb", self._key, self._compute_space, "PDB_CACHE", keep=("size", "keys", "rows"))
        self.size = int(space["size"])
        self.exhausted = self.size <= max_states
        if self.exhausted:
            self.keys, self.rows = space["keys"], space["rows"]
        self._edges = space if "label" in space else None
        self._backward_graph = None

    def edges(self) -> dict[str, np.ndarray]:
        """The transition graph's arrays (`_space`), explored once more if the states came from the cache."""
        if self._edges is None:
            self._edges = self._compute_space()
        return self._edges

    @property
    def _backward(self) -> csr_matrix:
        if self._backward_graph is None:
            self._backward_graph = self._graph(self.costs)
        return self._backward_graph

    def _graph(self, costs: np.ndarray) -> csr_matrix:
        """The reversed transition graph, each edge weighted by its cheapest operator under `costs`."""
        e = self.edges()
        cost = np.minimum.reduceat(self._ops.row_costs(costs)[e["label"]], e["first"])
        weight = np.where(cost > 0, cost, 1e-9).astype(float)  # a zero-cost action stays an edge
        return csr_matrix((weight, e["pair_source"], e["pair_start"]), shape=(self.size, self.size))

    def index(self, batch: np.ndarray) -> np.ndarray:
        """(N,) abstract state of each packed state; `size` for one outside the explored space."""
        proj = batch & self.mask
        keys = state_keys(proj)
        pos = np.minimum(np.searchsorted(self.keys, keys), self.size - 1)
        hit = (self.keys[pos] == keys) & (self.rows[pos] == proj).all(1)
        return np.where(hit, pos, self.size)

    def distances(self, pos: np.ndarray, neg: np.ndarray) -> np.ndarray:
        """(size + 1,) int64 cost from each abstract state to the nearest abstract goal state
        (INF_64: none reachable); the extra last entry, 0, answers states outside the space.
        The goal is a DNF as (K, W) pos/neg words (levels.goal_arrays). Kept in the cache."""
        pos, neg = pos & self.mask, neg & self.mask
        key = cache.digest(self._key, pos, neg, self.costs)
        compute = lambda: {
            "d": self._backward_from(np.where(satisfied(self.rows, pos, neg), 0, INF_64), self._backward)
        }
        return cache.arrays("pdb-goal", key, compute, "PDB_CACHE")["d"]

    def window_distances(self, tasks: list, costs: np.ndarray | None = None) -> list[np.ndarray]:
        """[(size + 1,) int64 per stage k]: the cost from each abstract state to complete tasks k, k+1, ...
        in order, where completing a task moves on through its (projected) consumption. Backwards
        from the last task: stage k starts at the goal states of task k with the cost-to-go of
        stage k + 1 from where the consumption leads. `costs`: per ground action (default the
        projection's)."""
        graph = self._backward if costs is None else self._graph(costs)
        after = np.zeros(self.size + 1, dtype=np.int64)
        out = [after]
        for task in reversed(tasks):
            start = np.full(self.size, INF_64, dtype=np.int64)
            done = _project_ops(self._model, self._bm, self._atom_mask, list(task.bindings), actions=False)
            for v in range(len(done.edge)):
                ok = np.flatnonzero(satisfied(self.rows, done.pos[v : v + 1], done.neg[v : v + 1]))
                nxt = (self.rows[ok] & done.keep[v]) | done.add[v]
                start[ok] = np.minimum(start[ok], after[self.index(nxt)])
            after = self._backward_from(start, graph)
            out.append(after)
        return out[::-1]

    def saturated(self, togo: list[np.ndarray], costs: np.ndarray) -> np.ndarray:
        """Per ground action, the least cost that keeps these distances (under `costs`) valid: the
        largest drop h(s) - h(t) over the abstract transitions s -> t it induces, at any stage,
        between states from which the goal is reachable (Seipp & Helmert's saturated cost
        function, floored at 0). What is left, costs - saturated, is free for other patterns."""
        e = self.edges()
        drop = np.zeros(len(self._ops.edge), dtype=np.int64)
        for h in togo:
            hs, ht = h[e["src"]], h[e["dst"]]
            ok = (hs < INF_64) & (ht < INF_64)
            np.maximum.at(drop, e["label"][ok], hs[ok] - ht[ok])
        drop = np.minimum(drop, self._ops.row_costs(costs))
        need = np.zeros(len(costs), dtype=np.int64)
        ops = self._ops
        owner = np.repeat(np.arange(len(ops.edge)), np.diff(ops.starts))
        np.maximum.at(need, ops.members, drop[owner])
        return need

    def _backward_from(self, start: np.ndarray, g: csr_matrix) -> np.ndarray:
        """(size + 1,) int64: min over abstract states t of start[t] + the cost from each state to t
        (Dijkstra on the reversed graph g from a source joined to each t by an edge of cost start[t])."""
        out = np.full(self.size + 1, INF_64, dtype=np.int64)
        out[-1] = 0
        src = np.flatnonzero(start < INF_64)
        if not len(src):
            return out
        n = self.size
        if not start[src].any():  # every source at 0 (goal distances): a multi-source search of g itself
            d = dijkstra(g, directed=True, indices=src, min_only=True)
            ok = np.isfinite(d)
            out[:-1][ok] = np.floor(d[ok] + 1e-6).astype(np.int64)
            return out
        weight = np.where(start[src] > 0, start[src], 1e-9).astype(float)
        graph = csr_matrix(
            (np.r_[g.data, weight], np.r_[g.indices, src], np.r_[g.indptr, g.indptr[-1] + len(src)]),
            shape=(n + 1, n + 1),
        )
        d = dijkstra(graph, directed=True, indices=n)[:n]
        ok = np.isfinite(d)
        out[:-1][ok] = np.floor(d[ok] + 1e-6).astype(np.int64)
        return out


def _project_ops(model, bm, atom_mask: int, consumption: list, actions: bool = True) -> _Ops:
    """Every action variant and task consumption, restricted to the pattern's atoms.

    A conditional effect gives two operators: it fires (its condition's kept
    literals join the precondition) or it does not (if its condition is one kept
    literal, that literal's negation joins the precondition; otherwise nothing is
    known and both operators stay, an over-approximation)."""
    rows = []  # (pos, neg, add, dele, is action, ground action or -1)
    sources = [(op, True, a) for op, a in zip(model.ops, model.op_action)] if actions else []
    sources += [(op, False, -1) for op in consumption]
    for op, is_action, action in sources:
        base = (op.pos & atom_mask, op.neg & atom_mask, op.add & atom_mask, op.dele & atom_mask)
        for fired in itertools.product((False, True), repeat=len(op.cond)):
            p, n, a_, d_ = base
            for (cp, cn, ca, cd), f in zip(op.cond, fired):
                if f:
                    p, n, a_, d_ = (
                        p | (cp & atom_mask),
                        n | (cn & atom_mask),
                        a_ | (ca & atom_mask),
                        d_ | (cd & atom_mask),
                    )
                elif not (cp | cn) & ~atom_mask and len(_bits(cp)) + len(_bits(cn)) == 1:
                    p, n = p | cn, n | cp
            if not p & n and (a_ & ~p or d_ & ~n or not is_action):
                rows.append((p, n, a_, d_, is_action, action))  # (an action changing nothing is a self-loop)
    merged = {}  # projections of different actions often coincide
    for r in rows:
        members = merged.setdefault(r[:5], set())
        if r[5] >= 0:
            members.add(r[5])
    keys = list(merged)
    pack = lambda col: bm.pack([k[col] for k in keys])
    members = [sorted(merged[k]) for k in keys]
    return _Ops(
        pack(0),
        pack(1),
        pack(2),
        ~pack(3),
        np.array([k[4] for k in keys], dtype=bool),
        np.array([a for m in members for a in m], dtype=np.int64),
        np.cumsum([0] + [len(m) for m in members]).astype(np.int64),
    )


def _applicability(ops: _Ops, n_words: int):
    """f(states) -> (N, V) bool, which operators apply in which packed states. An operator's precondition
    names few of the pattern's atoms (about 40 of either sign in the restaurant's and the blockworld's), so
    the states' bits on those atoms (N, b) times the operators' (b, V) counts the violated literals in one
    float32 product (exact: at most b), instead of testing every operator's words in turn."""
    need = np.bitwise_or.reduce(ops.pos | ops.neg, axis=0) if len(ops.pos) else np.zeros(n_words, np.uint64)
    where = [(w, j) for w in range(n_words) for j in range(64) if int(need[w]) >> j & 1]
    word = np.array([w for w, _ in where], dtype=np.int64)
    shift = np.array([j for _, j in where], dtype=np.uint64)
    bit = lambda packed: ((packed[:, word] >> shift) & np.uint64(1)).astype(np.float32)  # (N, b) 0/1
    pos, neg = bit(ops.pos), bit(ops.neg)  # (V, b)
    # violated literals = Σ_b pos (1 - s) + neg s = |pos| + s · (neg - pos)
    base, delta = pos.sum(1), np.ascontiguousarray((neg - pos).T)
    return lambda states: bit(states) @ delta + base == 0


def _explore(bm, ops: _Ops, seeds: np.ndarray, max_states: int):
    """Breadth-first exploration of the abstract space from its seeds: (sorted keys, their rows,
    edge sources, edge targets, edge operator rows) with states numbered in key order; edges are the
    actions' only (consumption only makes states reachable). States are deduplicated by 64-bit
    key and every key match is checked against the stored row (a collision raises)."""
    W = bm.n_words
    applicable = _applicability(ops, W)
    frontier = np.unique(seeds, axis=0)
    seen = StateTable(W)
    seen.add(state_keys(frontier), frontier, np.arange(len(frontier)))
    n = len(frontier)
    src, dst, labels = [], [], []
    lo_id = 0
    while len(frontier) and n <= max_states:
        children, sources, edge = [], [], []
        for lo in range(0, len(frontier), CHUNK):
            part = frontier[lo : lo + CHUNK]
            r, v = np.nonzero(applicable(part))
            children.append((part[r] & ops.keep[v]) | ops.add[v])
            sources.append(lo_id + lo + r)
            edge.append(v)
        child = np.concatenate(children)
        ck, first, back = np.unique(state_keys(child), return_index=True, return_inverse=True)
        back = back.ravel()
        if (child[first][back] != child).any():
            raise RuntimeError("two abstract states share a 64-bit key")
        child = child[first]
        run, at = seen.find(ck, child)
        new = run < 0
        ids = seen.get(run, at)
        ids[new] = np.arange(n, n + new.sum())
        v = np.concatenate(edge)
        act = ops.edge[v]
        src.append(np.concatenate(sources)[act])
        dst.append(ids[back[act]])
        labels.append(v[act])
        lo_id = n
        frontier = child[new]
        seen.add(ck[new], frontier, ids[new])
        n += len(frontier)
    sorted_keys, rows, ids = seen.merged()
    rank = np.empty(n, dtype=np.int64)
    rank[ids] = np.arange(n)  # id -> position in key order
    cat = lambda parts, dtype: np.concatenate(parts) if parts else np.zeros(0, dtype=dtype)
    return sorted_keys, rows, rank[cat(src, np.int64)], rank[cat(dst, np.int64)], cat(labels, np.int64)


def _space(bm, ops: _Ops, seeds: np.ndarray, max_states: int) -> dict[str, np.ndarray]:
    """A projection's abstract space as arrays (what `Projection` keeps, cached on disk by `planning.cache`):
    its size, and where it has at most max_states states, their sorted keys and rows and its edges (source,
    target, operator row), sorted by (target, source) for the reversed graph, with the first edge of each
    (source, target) pair and each pair's source and start per target (the reversed graph's CSR arrays)."""
    keys, rows, src, dst, label = _explore(bm, ops, seeds, max_states)
    size = len(keys)
    if not size or size > max_states:
        return {"size": np.array(size)}
    n_ops = len(ops.edge)
    edge = np.sort((dst * size + src) * n_ops + label)  # < 2^63: size^2 * ops
    edge = edge[np.r_[True, edge[1:] != edge[:-1]]]
    pair = edge // n_ops
    first = np.flatnonzero(np.r_[True, pair[1:] != pair[:-1]])
    unique = pair[first]
    return {
        "size": np.array(size),
        "keys": keys,
        "rows": rows,
        "src": (pair % size).astype(np.int32),
        "dst": (pair // size).astype(np.int32),
        "label": (edge % n_ops).astype(np.int32),
        "first": first,
        "pair_source": unique % size,
        "pair_start": np.searchsorted(unique // size, np.arange(size + 1)),
    }


class PatternDatabases:
    """Per-task admissible estimates from projections onto each goal binding's objects and their neighbours.

    `per_task(batch)` -> (N, T) int64: for every task of the model, the smallest over its goal
    bindings of the largest distance over that binding's patterns (INF_64: a dead end).
    """

    name = "pdb"

    def __init__(
        self, model, bm: BatchedModel | None = None, tasks=None, max_states: int = 200_000, max_objects: int = 3
    ):
        self.model = model
        self.bm = bm or BatchedModel(model)
        self.tasks = list(model.tasks.tasks if tasks is None else tasks)
        locations = set(model.locations)
        if not locations:
            raise DomainError(
                model.files["config"],
                f"[layouts.{model.layout}] lists no rooms: pattern databases need to know the locations",
            )
        consumption = [op for t in model.tasks.tasks for op in t.bindings]
        changed = 0
        for op in [*model.ops, *consumption]:
            changed |= _changes(op)
        for choices, _ in model.resets:
            for c in choices:
                changed |= c
        self._changed = changed
        # Each atom's objects (its arguments that are not locations); an unchanging atom has none.
        self.atom_objects = [
            frozenset(a[1:]) - locations if changed >> i & 1 else frozenset() for i, a in enumerate(model.atoms)
        ]
        self.objects = sorted(set().union(*self.atom_objects), key=model.objects.index)
        # Objects that share a ground action are neighbours.
        self.neighbours = {o: set() for o in self.objects}
        for op in model.ops:
            objs = set()
            for i in _bits(op.pos | op.neg | op.add | op.dele):
                objs |= self.atom_objects[i]
            for o in objs:
                self.neighbours[o] |= objs - {o}
        self.seeds = self.bm.pack(_reset_states(model))
        self._consumption = consumption
        self._max_states = max_states
        self.max_objects = max_objects
        self.projections: dict[frozenset, tuple] = {}  # objects -> (projection or None, budget tried)
        # The distance tables of each goal binding's patterns, stacked into one array; a binding
        # maps to its (projection, offset) pairs (none: it reads the leading 0).
        self._tables: dict[tuple, list] = {}
        self._chunks, self._size, self._stacked = [np.zeros(1, dtype=np.int64)], 1, None
        self._plans: dict = {}
        self._windows: OrderedDict = OrderedDict()  # least recently used first, WINDOW_CACHE_BYTES in all
        self._additive: dict = {}
        self.building = 0.0  # seconds spent building window estimates (`window`), which search clocks leave out
        for task in self.tasks:
            for op in task.bindings:
                self.tables(op)

    def tables(self, op) -> tuple[list, list]:
        """(projection, offset into the stacked tables) per pattern of one goal binding, in two
        lists: the patterns whose largest value counts and the additive ones whose sum counts
        (built once)."""
        key = (op.pos, op.neg)
        if key not in self._tables:
            pos, neg = self.bm.pack([op.pos]), self.bm.pack([op.neg])
            lists = []
            for patterns in (self.patterns(op), self.additive(op)):
                pairs = []
                for p in patterns:
                    self._chunks.append(p.distances(pos, neg))
                    pairs.append((p, self._size))
                    self._size += len(self._chunks[-1])
                lists.append(pairs)
            self._tables[key] = tuple(lists)
            self._stacked = None
        return self._tables[key]

    def additive(self, op) -> list:
        """For a goal over several objects: one projection per object onto that object's own atoms
        (no agent atoms), each action's cost given to the first of them whose atoms it changes and
        0 in the others, so their distances add up admissibly (a cost partitioning, Katz & Domshlak
        2008): clearing a table needs every object on it picked and placed."""
        objects = sorted(self.goal_objects(op), key=self.model.objects.index)
        if len(objects) < 2:
            return []
        key = tuple(objects)
        if key not in self._additive:
            m = self.model
            own = {o: 0 for o in objects}
            for i, objs in enumerate(self.atom_objects):
                if len(objs) == 1 and next(iter(objs)) in own:
                    own[next(iter(objs))] |= 1 << i
            fixed = 0  # atoms nothing changes (the fountain's place)
            for i, objs in enumerate(self.atom_objects):
                if not objs and not self._changed >> i & 1:
                    fixed |= 1 << i
            owner = {}
            for o2, a in zip(m.ops, m.op_action):
                first = next((o for o in objects if _changes(o2) & own[o]), None)
                if first is not None:
                    owner.setdefault(a, first)
            out = []
            for o in objects:
                costs = [c if owner.get(a) == o else 0 for a, c in enumerate(m.action_cost)]
                p = Projection(
                    m, self.bm, frozenset([o]), own[o] | fixed, self.seeds, self._consumption, self._max_states, costs
                )
                if p.exhausted:
                    out.append(p)
            self._additive[key] = out
        return self._additive[key]

    def goal_objects(self, op) -> frozenset:
        out = frozenset()
        for i in _bits(op.pos | op.neg):
            out |= self.atom_objects[i]
        return out

    def patterns(self, op) -> list:
        """A binding's patterns: its goal's objects with each neighbour; where none of those fits
        the budget (or the goal has max_objects objects or more), the goal's objects alone; where
        that does not fit either, each of them on its own."""
        base = self.goal_objects(op)
        order = lambda objs: sorted(objs, key=self.model.objects.index)
        groups = [[base], [frozenset([o]) for o in order(base)]]
        if len(base) < self.max_objects:
            near = set().union(*(self.neighbours[o] for o in base)) - base
            groups.insert(0, [base | {x} for x in order(near)])
        for group in groups:
            found = [p for p in map(self.projection, group) if p is not None]
            if found:
                return found
        return []

    def projection(self, objects: frozenset, max_states: int | None = None) -> Projection | None:
        """The projection onto these objects (built once; None if it has more than max_states states)."""
        budget = max_states or self._max_states
        p, tried = self.projections.get(objects, (None, 0))
        if p is None and tried < budget:
            mask = 0
            for i, objs in enumerate(self.atom_objects):
                if objs <= objects:
                    mask |= 1 << i
            # Whatever decides whether a conditional effect on the pattern fires is kept too
            # (pouring restores the machine's water only from a vessel that holds water).
            for op in self.model.ops:
                for cp, cn, ca, cd in op.cond:
                    if (ca | cd) & mask:
                        mask |= op.pos | op.neg | cp | cn
            p = Projection(self.model, self.bm, objects, mask, self.seeds, self._consumption, budget)
            p = p if p.exhausted else None
            self.projections[objects] = (p, budget)
        return p if p is not None and p.size <= budget else None

    def window(self, tasks: list, sample: np.ndarray | None = None, max_states: int = 1_000_000, grow: int = 0) -> list:
        """[[(projection, [(size + 1,) cost-to-go per stage]), ...] per estimate, whose values add] for
        completing `tasks` in order (a clairvoyant window from its current stage on); built once per
        window, `sample` (packed states, e.g. the search's first) guides the choice below.

        Patterns: the goal objects of as many leading tasks as fit in max_states abstract states,
        and each task's own goal objects, each group alone and with each neighbour. Each pattern
        follows every stage of the window: a task's goal atoms outside the pattern are dropped (an
        easier goal), so every pattern's cost-to-go is admissible under the full costs, and so is
        the sum of disjoint patterns under a saturated cost partitioning (`saturated_window`):
        for each group in turn, the pattern with the largest estimate on the sample among those
        that contain it and share no object with the ones already chosen (two coffees' cups and
        water machine, then a fruit bowl's apple, bowl and knife), partitioned in each rotation of
        that order (the first pattern takes the moves it needs). The estimate is the largest.

        grow > 0: the pattern with the largest estimate on the sample and each chosen one (one per task
        group) is grown by one neighbour object (a step of
        Haslum et al.'s 2007 hill climbing over patterns): each neighbour in turn, in a projection of up
        to `grow` abstract states; the best, where it raises the sample's estimate, adds two estimates:
        alone, and first in a saturated partition with the chosen patterns it shares no object with (two
        coffees' cups and machine water with the jar, whose place decides what a refill from it costs).
        Every estimate without it is kept, so growing never lowers the estimate."""
        key = (tuple(t.index for t in tasks), max_states, grow)
        if key in self._windows:
            self._windows.move_to_end(key)
        else:
            t0 = time.perf_counter()
            objects = lambda task: frozenset().union(*(self.goal_objects(op) for op in task.bindings))
            base, covered = frozenset(), 0
            for task in tasks:
                if self.projection(base | objects(task), max_states) is None:
                    break
                base, covered = base | objects(task), covered + 1
            groups = ([base] if covered else []) + [objects(t) for t in tasks]
            sets = {}
            for group in groups:
                near = set().union(*(self.neighbours[o] for o in group)) - group
                for o in [group] + [group | {x} for x in sorted(near, key=self.model.objects.index)]:
                    sets.setdefault(o)
            found = [p for p in (self.projection(o, max_states) for o in sets) if p is not None]
            alone = {p: p.window_distances(tasks) for p in found}
            estimates = [[(p, togo)] for p, togo in alone.items()]
            value = lambda p: (int(alone[p][0][p.index(sample)].min()) if sample is not None else 0, p.size)
            order, used = [], frozenset()
            for group in groups:
                fits = [p for p in found if group <= p.objects and not p.objects & used]
                if group and fits:
                    order.append(max(fits, key=value))
                    used |= order[-1].objects
            for i in range(len(order) if len(order) > 1 else 0):  # each pattern first once
                turn = order[i:] + order[:i]
                estimates.append(self.saturated_window(tasks, turn, alone[turn[0]]))
            grown_from = [max(found, key=value), *order] if grow and found and sample is not None else []
            for p in dict.fromkeys(grown_from):  # the best pattern, then each chosen one (once each)
                grown = self._grow(tasks, sample, p, alone, grow)
                if grown is not None:  # one more estimate alone, and first in a partition with the disjoint rest
                    estimates.append([(grown, alone[grown])])
                    rest = [q for q in order if not q.objects & grown.objects]
                    if rest:
                        estimates.append(self.saturated_window(tasks, [grown, *rest], alone[grown]))
            self._windows[key] = estimates
            self._evict_windows()
            self.building += time.perf_counter() - t0
        return self._windows[key]

    def _grow(self, tasks: list, sample: np.ndarray, best, alone: dict, budget: int) -> Projection | None:
        """`best` grown by the neighbour object that raises the sample's estimate most (see `window`), its
        distances added to `alone`; None where no neighbour fits the budget or raises the estimate."""
        value = lambda p, togo: int(togo[0][p.index(sample)].min())
        near = set().union(*(self.neighbours[o] for o in best.objects)) - best.objects
        top, top_value = None, value(best, alone[best])
        for x in sorted(near, key=self.model.objects.index):
            p = self.projection(best.objects | {x}, budget)
            if p is None or p in alone:
                continue
            togo = p.window_distances(tasks)
            v = value(p, togo)
            if v > top_value:
                top, top_value, top_togo = p, v, togo
        if top is not None:
            alone[top] = top_togo
        return top

    def _evict_windows(self) -> None:
        """Forget the least recently used windows' distances beyond WINDOW_CACHE_BYTES (a K = 4 run
        over ten sequences meets hundreds of windows; their tables took 13 GB)."""
        size = lambda estimates: sum(t.nbytes for parts in estimates for _, togo in parts for t in togo)
        total = sum(size(e) for e in self._windows.values())
        while total > WINDOW_CACHE_BYTES and len(self._windows) > 1:
            total -= size(self._windows.popitem(last=False)[1])

    def saturated_window(self, tasks: list, order: list, first: list | None = None) -> list:
        """[(projection, cost-to-go per stage)] of a saturated cost partitioning over window patterns
        (Seipp, Keller & Helmert 2020): each pattern in turn gets the costs the ones before it did
        not need to keep their distances, so the distances add up admissibly. `first`: the first
        pattern's distances under the full costs, if already known."""
        rest = np.asarray(self.model.action_cost, dtype=np.int64).copy()
        out = []
        for i, p in enumerate(order):
            togo = first if i == 0 and first is not None else p.window_distances(tasks, rest)
            out.append((p, togo))
            if i + 1 < len(order):
                rest = rest - p.saturated(togo, rest)
        return out

    def window_estimate(self, batch: np.ndarray, tasks: list, grow: int = 0) -> np.ndarray:
        """(N,) int64 admissible cost of completing `tasks` in order from each state of the batch (the
        stage of tasks[0]): the largest over `window(tasks)`'s estimates (INF_64: a dead end)."""
        out = np.zeros(len(batch), dtype=np.int64)
        for parts in self.window(tasks, batch[:1], grow=grow):
            total = np.zeros(len(batch), dtype=np.int64)
            for proj, togo in parts:
                total += np.minimum(togo[0][proj.index(batch)], _PART_INF)
            out = np.maximum(out, np.where(total >= _PART_INF, INF_64, total))
        return out

    def per_task(self, batch: np.ndarray, tasks=None) -> np.ndarray:
        """(N, T') int64 admissible cost of each of the model's `tasks` (indices; default all)."""
        tasks = range(len(self.tasks)) if tasks is None else tasks
        return self.per_goal(batch, [self.tasks[t] for t in tasks], key=("tasks", *tasks))

    def per_goal(self, batch: np.ndarray, goals: list, key=None) -> np.ndarray:
        """(N, G) int64 admissible cost of each goal (anything with `bindings`, a DNF of Ops: a task,
        or a task with an extra clause) from each state (INF_64: a dead end), in one gather over the
        stacked distance tables. `key` names the goal list for reuse of its gather plan."""
        key = key if key is not None else tuple(tuple((o.pos, o.neg) for o in g.bindings) for g in goals)
        if key not in self._plans:
            self._plans[key] = self._plan(goals)
        if self._stacked is None:
            self._stacked = np.concatenate(self._chunks)
        projections, maxed, summed, goal_starts = self._plans[key]
        idx = np.stack([p.index(batch) for p in projections], axis=1)  # (N, projections)
        column, offset, starts = maxed
        h = np.maximum.reduceat(self._stacked[offset + idx[:, column]], starts, axis=1)
        column, offset, starts = summed
        part = np.minimum(self._stacked[offset + idx[:, column]], _PART_INF)
        total = np.add.reduceat(part, starts, axis=1)
        h = np.maximum(h, np.where(total >= _PART_INF, INF_64, total))
        return np.minimum.reduceat(h, goal_starts, axis=1)

    def _plan(self, goals) -> tuple:
        """Which projections, table offsets and reduce boundaries answer a list of goals."""
        projections, where, goal_starts = [], {}, []
        cols = ([], [], [], []), ([], [], [], [])  # maxed, summed: column, offset, binding starts
        for goal in goals:
            goal_starts.append(len(cols[0][2]))
            for op in goal.bindings:
                for (column, offset, starts, _), pairs in zip(cols, self.tables(op)):
                    starts.append(len(column))
                    for p, off in pairs or [(_NOWHERE, 0)]:
                        if id(p) not in where:
                            where[id(p)] = len(projections)
                            projections.append(p)
                        column.append(where[id(p)])
                        offset.append(off)
        arrays = [(np.array(c), np.array(o, dtype=np.int64), np.array(s)) for c, o, s, _ in cols]
        return projections, arrays[0], arrays[1], np.array(goal_starts)


class _Nowhere:
    """The projection of a binding without patterns: every state maps to the stacked tables' leading 0."""

    objects = None

    @staticmethod
    def index(batch):
        return np.zeros(len(batch), dtype=np.int64)


_NOWHERE = _Nowhere()
_PART_INF = INF_64 // 64  # summands are clipped here: a sum of up to 64 never overflows


@lru_cache(maxsize=8)
def pattern_databases(model, n_words: int) -> PatternDatabases:
    """The pattern databases of a compiled layout for packed states of n_words words, built once
    per process (every search over the layout shares them)."""
    bm = BatchedModel(model, extra_bits=n_words * 64 - model.n_atoms)
    return PatternDatabases(model, bm)


GROW_STATES = 4_000_000
"""Abstract states of a grown window pattern (`build_grown`): the restaurant's two cups, machine water and jar
take 2.75 million."""


def build(bm, search: str, grow: int = 0):
    """The registry's builder (planning.heuristics): the layout's pattern databases, the nearest goal's estimate
    (task and multi-goal searches), or in the window the larger of the current stage's and the window's."""
    pdb = pattern_databases(bm.model, bm.n_words)
    if search == "window":

        def h(batch, goals):
            return np.maximum(pdb.per_goal(batch, goals[:1])[:, 0], pdb.window_estimate(batch, goals, grow))

        h.building = lambda: pdb.building  # what a search's time limit leaves out
        return h
    return lambda batch, goals: pdb.per_goal(batch, goals).min(1)


def build_grown(bm, search: str):
    """The window's pattern databases with each chosen window pattern grown by one neighbour (`window`'s grow)."""
    return build(bm, search, GROW_STATES)


def _reset_states(model, limit: int = 4096) -> list[int]:
    """The initial state and every combination of the world-reset choices (up to `limit`)."""
    states = {model.init}
    combos = itertools.product(*[choices for choices, _ in model.resets])
    for combo in itertools.islice(combos, limit):
        s = model.init
        for (choices, _), c in zip(model.resets, combo):
            every = 0
            for x in choices:
                every |= x
            s = (s & ~every) | c
        states.add(s)
    return sorted(states)

"""The supervised dataset of the one-task GNN baseline (thesis §5.2.2 items 3-4, Appendix A.1).

faithful   states the myopic oracle visits on seeded task streams (oracles.rollouts,
           cached on disk): the world before the first task and after each reset,
           the states along each executed plan, and each task's post-consumption world
           (a plan's last state before consumption is not kept: no task starts there).
augmented  those, plus counterfactual *prepared* states the myopic plans never visit.
           Four more persistent task streams (seeds seed + 1 .. seed + 4, whatever the
           number of workers) are planned, optimally, for each task AND one preparatory
           clause, and the states along those plans are kept.

The clause library is derived from the domain, with no names in Python. A literal
(an atom or its negation) of a ground action's precondition is a clause (a) if
some action that needs it leaves it standing (refill-water needs the jar to hold
water and keeps it so; fill needs a clean vessel), or (b) if it is a positive
resource that the action needing it uses up and only an action costing at least
`min_clause_cost` restores (make-coffee uses up the machine water, pour at 200
restores it). Literals every consumer undoes and anyone can cheaply redo (an
object at a place, which pick undoes; a dirty object, which wash undoes) are not
preparation. Also a clause: every pair of positive precondition atoms of one
ground action whose first argument is the same object (refill-water's "the jar
holds water" and "the jar is at l": a filled jar parked where water is drawn)
that the action leaves standing.
Literals about the agent itself (planning.domain.roles.agent_predicates: its position,
hand and grip) are left out: they do not outlast the next task. At each task a clause is drawn uniformly among
those that are false in the current world and whose relaxed cost (h_max from that
world) is at least `min_clause_cost`, so it means real preparation: the jar
filled, the jar at a place where water is used, an object clean, the machine
water restored. The joint plan is executed to its end, then the task's
consumption is applied.

Every state is labelled with C_AP by oracles.labelling (exact, all task
instantiations, one multi-goal search per state), in the worker processes that
also collect the prepared streams (the states found so far are labelled while
the streams run);
labels are checkpointed atomically in OUT/labels.partial.json, so an interrupted
run resumes where it stopped. The result is a torch-geometric dataset:
OUT/processed/data.pt (graphs from learning.gnn.graph with y = C_AP and the per-task
costs) and OUT/meta.json (each state's true atoms, the task list, the feature and
relation names, the configuration, the timings, and the domain's identity:
`planning.domain.identity`).

    python -m learning.gnn_dataset --layout three-room [--augmented] --n-states 2000 [--out DIR] [--force]

OUT defaults to runs/gnn/DOMAIN-LAYOUT-KIND (KIND faithful or augmented). One process
writes a folder at a time (`planning.atomic.OutputLock`). A finished dataset (its
meta.json) of another layout, size or domain content is never replaced unless
--force; the same configuration again is rebuilt from its label checkpoint. The
caches inside the folder (the label checkpoint, the prepared streams' plans) record
the layout and the domain's identity, and those made from other content are started
afresh.
"""

from __future__ import annotations

import json
import multiprocessing as mp
import os
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
from tqdm import tqdm

from learning.gnn.candidates import JOINT_HEURISTIC
from oracles.rollouts import faithful_states
from planning import cli
from planning.atomic import OutputLock, write_json
from planning.domain.grounding import atom_text
from planning.domain.identity import identity, mismatch
from planning.errors import DomainError

CHECKPOINT_SECONDS = 10.0
CONTENT_KEYS = (
    "n_states",
    "augmented",
    "n_prepared",
    "seed",
    "prepared_streams",
    "min_clause_cost",
    "plan_time_limit",
    "label_time_limit",
)
"""The settings that change what a dataset holds (the workers and the exact search's heuristic do not)."""


@dataclass
class DatasetConfig:
    """What gnn_dataset builds; defaults follow the thesis (2,000 faithful states)."""

    layout: str = "three-room"
    domain: str = cli.DEFAULT_DOMAIN
    n_states: int = 2000  # faithful states
    augmented: bool = False
    n_prepared: int | None = None  # prepared states added when augmented (default 3 x n_states: 8,000 in all)
    seed: int = 0  # seed of the myopic rollout; prepared stream i uses seed + 1 + i
    workers: int = 2  # processes collecting prepared states and labelling
    prepared_streams: int = 4  # independent prepared task streams (seeds seed + 1 ...), whatever the workers
    heuristic: str = "pdb"  # of the labelling search (oracles.labelling.HEURISTICS)
    label_time_limit: float | None = None  # seconds per label (None: exact, however long)
    plan_time_limit: float = 120.0  # seconds per joint task + clause plan before falling back to the task alone
    min_clause_cost: int = 200  # a clause must cost at least this much (h_max) to count as preparation


# ---- states ------------------------------------------------------------------------------
class ClauseLibrary:
    """Preparatory goal clauses derived from the domain's action preconditions (see the module docstring)."""

    def __init__(self, model, min_cost: int = 200):
        """`min_cost`: the cheapest restoring action that makes a used-up precondition a resource."""
        from planning.domain.roles import agent_predicates

        self.model, self.min_cost = model, min_cost
        agent = agent_predicates(model)
        n = model.n_atoms
        world = [i for i in range(n) if model.atoms[i][0] not in agent]
        keep = 0
        for i in world:
            keep |= 1 << i
        undone = {}  # literal -> does every action requiring it undo it?
        cheapest = {}  # atom -> cheapest cost of an action adding it
        for op, a in zip(model.ops, model.op_action):
            for i in _bits(op.add | _cond_adds(op)):
                cheapest[i] = min(cheapest.get(i, 1 << 62), model.action_cost[a])
            for i in _bits(op.pos & keep):
                undone[(i, True)] = undone.get((i, True), True) and bool(op.dele >> i & 1)
            for i in _bits(op.neg & keep):
                undone[(i, False)] = undone.get((i, False), True) and bool(op.add >> i & 1)
        clauses = set()
        for (i, positive), gone in undone.items():
            # (a) some action needs it and leaves it standing, or (b) a resource an action
            # uses up and only a costly action restores (the machine water)
            if not gone or (positive and cheapest.get(i, 0) >= self.min_cost):
                clauses.add(((i,), ()) if positive else ((), (i,)))
        for op in model.ops:
            pos = [i for i in _bits(op.pos & keep) if not op.dele >> i & 1]  # left standing by the action
            for a in pos:
                for b in pos:
                    ka, kb = model.atoms[a], model.atoms[b]
                    if a < b and ka[0] != kb[0] and len(ka) > 1 and len(kb) > 1 and ka[1] == kb[1]:
                        clauses.add(((a, b), ()))
        self.clauses = sorted(clauses)
        self.masks = [(sum(1 << i for i in p), sum(1 << i for i in q)) for p, q in self.clauses]

    def __len__(self) -> int:
        return len(self.clauses)

    def text(self, k: int) -> str:
        """A clause as PDDL-like text, e.g. '(and (at jar_0 servingtable) (has-water jar_0))'."""
        p, q = self.clauses[k]
        lits = [atom_text(self.model.atoms[i]) for i in p] + [f"(not {atom_text(self.model.atoms[i])})" for i in q]
        return lits[0] if len(lits) == 1 else f"(and {' '.join(lits)})"

    def eligible(self, state: int, hmax, bm, min_cost: int) -> list[int]:
        """The clauses false in `state` whose relaxed cost from it is at least min_cost."""
        false = [k for k, (p, q) in enumerate(self.masks) if not (state & p == p and not state & q)]
        if not false:
            return []
        n = self.model.n_atoms
        goal = [[*self.clauses[k][0], *(n + i for i in self.clauses[k][1])] for k in false]
        cost = hmax.literal_costs(bm.pack([state]), goal)[0]
        return [
            k
            for k, lits in zip(false, goal)
            if int(cost[lits].max()) >= min_cost and int(cost[lits].max()) < np.iinfo(np.int32).max // 4
        ]


class JointGoal:
    """A task's goal AND a clause: the task's DNF with the clause added to every conjunction."""

    def __init__(self, task, pos: int, neg: int):
        from planning.domain.model import Op

        self.task, self.name = task, f"{task.name} + clause"
        self.bindings = tuple(Op(o.pos | pos, o.neg | neg, 0, 0) for o in task.bindings)

    def satisfied(self, state: int) -> bool:
        """True if the task's goal and the clause both hold."""
        return any(state & o.pos == o.pos and not state & o.neg for o in self.bindings)


def prepared_states(
    model,
    n: int,
    cfg: DatasetConfig,
    cache: Path,
    progress: bool = True,
    stream: int = 0,
    exclude=frozenset(),
    counter=None,
) -> list[int]:
    """n distinct states, none in `exclude`, along optimal plans for (task AND a preparatory clause)
    on the seeded task stream number `stream` (seed cfg.seed + 1 + stream).

    The executed plans are kept in `cache` (written atomically), so a rerun replays them.
    `counter` (a multiprocessing Value) counts the states found, for a progress bar elsewhere.
    """
    from planning.domain.batched import BatchedModel
    from planning.heuristics.hmax import HMax
    from planning.search.optimal import optimal_plan
    from planning.world.task_stream import TaskStream

    seed = cfg.seed + 1 + stream
    bm = BatchedModel(model)
    hmax = HMax(model, bm)
    library = ClauseLibrary(model, cfg.min_clause_cost)
    rng = np.random.default_rng(seed)
    task_stream = TaskStream(model, seed)
    header = {
        "layout": model.layout,
        "seed": seed,
        **identity(model),
        "min_clause_cost": cfg.min_clause_cost,
        "plan_time_limit": cfg.plan_time_limit,
    }
    done = cached_plans(cache, header, model)
    rows: list[dict] = []
    states: dict[int, None] = {}
    state = None
    bar = tqdm(total=n, desc=f"prepared states {model.layout}", unit="state", disable=not progress)

    def keep(path):
        new = [s for s in dict.fromkeys(path) if s not in states and s not in exclude][: n - len(states)]
        states.update(dict.fromkeys(new))
        bar.update(len(new))
        if counter is not None:
            with counter.get_lock():
                counter.value += len(new)

    last_save = time.monotonic()
    i = 0
    while len(states) < n:
        task, reset = task_stream.next()
        if reset is not None:
            state = model.reset_state(reset)
            keep([state])
        clause = int(rng.integers(1 << 30))  # drawn every task, so a replay draws the same
        if i < len(done):
            row = done[i]
            if row["task"] != task.name:
                raise DomainError(cache, f"task {i} is {row['task']}, but the stream draws {task.name}")
            plan = [model.action(a) for a in row["plan"]]
        else:
            row, plan = _plan_prepared(model, bm, hmax, library, state, task, clause, cfg, optimal_plan)
        path = [state]
        for a in plan:
            path.append(model.apply(path[-1], a))
        state = path[-1]
        if task.satisfied(state):
            path.pop()  # the goal state itself: no task starts there
            state = task.consume(state)
            path.append(state)
        keep(path)
        if i >= len(done):
            rows.append(row)
        i += 1
        if rows and time.monotonic() - last_save > CHECKPOINT_SECONDS:
            write_json(cache, {**header, "tasks": done + rows})
            last_save = time.monotonic()
    bar.close()
    if rows:
        write_json(cache, {**header, "tasks": done + rows})
    return list(states)


def cached_plans(cache: Path, header: dict, model) -> list[dict]:
    """The task rows a prepared stream's cache holds for this stream, layout and domain content; [] for a
    cache made otherwise (a cache: planned again and replaced); a corrupt one is a one-line error."""
    if not cache.is_file():
        return []
    try:
        saved = json.loads(cache.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise DomainError(
            cache, f"corrupt prepared-stream cache ({type(e).__name__}); delete it to plan again"
        ) from None
    if (
        not isinstance(saved, dict)
        or not isinstance(saved.get("tasks"), list)
        or not all(isinstance(r, dict) and isinstance(r.get("plan"), list) for r in saved["tasks"])
    ):
        raise DomainError(cache, "corrupt prepared-stream cache (no list of task rows); delete it to plan again")
    recorded = {k: saved[k] for k in header if k in saved and k not in ("domain_sha256", "domain_files")}
    if any(header[k] != v for k, v in recorded.items()) or mismatch(saved, model) is not None:
        return []
    return saved["tasks"]


def _plan_prepared(model, bm, hmax, library, state, task, draw, cfg, optimal_plan):
    """(cache row, plan) of one task planned with a drawn eligible clause, or alone if none fits in time."""
    eligible = library.eligible(state, hmax, bm, cfg.min_clause_cost)
    row = {"task": task.name, "clause": None, "plan": []}
    if task.satisfied(state):
        return row, []
    plan = None
    if eligible:
        k = eligible[draw % len(eligible)]
        pos, neg = library.masks[k]
        r = optimal_plan(
            bm, state, JointGoal(task, pos, neg), time_limit=cfg.plan_time_limit, heuristic=JOINT_HEURISTIC
        )
        if r.plan is not None:
            plan, row["clause"] = r.plan, library.text(k)
    if plan is None:
        r = optimal_plan(bm, state, task)
        plan = r.plan or []
    row["plan"] = [model.actions[a] for a in plan]
    return row, plan


def _cond_adds(op) -> int:
    """The atoms an op's conditional effects may add."""
    out = 0
    for _, _, add, _ in op.cond:
        out |= add
    return out


def _bits(mask: int) -> list[int]:
    return [i for i in range(mask.bit_length()) if mask >> i & 1]


# ---- collection and labelling in worker processes ---------------------------------------
_WORKER: dict = {}


def _init_worker(cfg: DatasetConfig, counter) -> None:
    from oracles.labelling import Labeller
    from planning.domain.compiler import compile_domain

    model = compile_domain(cfg.domain, cfg.layout)
    _WORKER.update(cfg=cfg, model=model, counter=counter, labeller=Labeller(model, cfg.heuristic, cfg.label_time_limit))


def _label_chunk(states: list[int]) -> list[tuple]:
    out = []
    for s in states:
        lab = _WORKER["labeller"].label(s)
        out.append((s, lab.c_ap, [int(c) for c in lab.costs], lab.seconds, lab.complete))
    return out


def _collect_stream(stream: int, n: int, cache: Path, exclude: frozenset) -> list[int]:
    return prepared_states(
        _WORKER["model"],
        n,
        _WORKER["cfg"],
        cache,
        progress=False,
        stream=stream,
        exclude=exclude,
        counter=_WORKER["counter"],
    )


class _Done:
    """A job already done: what apply_async of _InProcess returns."""

    def __init__(self, value):
        self.value = value

    def ready(self) -> bool:
        return True

    def get(self):
        return self.value


class _InProcess:
    """The Pool interface for one worker: every job runs in this process when it is submitted."""

    def __init__(self, cfg, counter):
        self.args = (cfg, counter)

    def apply_async(self, fn, args) -> _Done:
        cfg, counter = self.args
        if _WORKER.get("cfg") != cfg:
            _init_worker(cfg, counter)
        _WORKER["counter"] = counter  # this build's progress counter, not an earlier one's
        return _Done(fn(*args))

    def terminate(self) -> None:
        pass


class Workers:
    """Collect prepared streams and label states in one pool of cfg.workers processes, so that
    labelling runs beside the collection; labels are checkpointed atomically every few seconds."""

    def __init__(self, cfg: DatasetConfig, checkpoint: Path, known: dict | None = None, progress: bool = True):
        from planning.domain.compiler import compile_domain

        self.cfg, self.checkpoint, self.progress = cfg, checkpoint, progress
        model = compile_domain(cfg.domain, cfg.layout)
        self.header = {**identity(model), "layout": model.layout}
        self.labels = dict(known or {})
        if checkpoint.is_file():
            labels, saved = read_labels(checkpoint)
            if saved.get("layout") in (None, model.layout) and mismatch(saved, model) is None:
                self.labels.update(labels)  # else labels of other states: labelled again
        self.counter = mp.get_context("fork").Value("q", 0)
        self._pool = None
        self._pending: list = []  # label jobs not yet collected
        self._queued: set[int] = set()
        self._bar = tqdm(total=0, desc="labelling C_AP", unit="state", disable=not progress)
        self._last_save = time.monotonic()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.save()
        self._bar.close()
        if self._pool is not None:
            self._pool.terminate()

    @property
    def pool(self):
        if self._pool is None:
            args = (self.cfg, self.counter)
            self._pool = (
                _InProcess(*args)
                if self.cfg.workers <= 1
                else mp.get_context("fork").Pool(self.cfg.workers, initializer=_init_worker, initargs=args)
            )
        return self._pool

    def save(self) -> None:
        write_json(self.checkpoint, {**self.header, "labels": {str(s): list(v) for s, v in self.labels.items()}})
        self._last_save = time.monotonic()

    def label(self, states: list[int]) -> None:
        """Queue the states not labelled yet, in contiguous chunks (neighbours share cached estimates)."""
        new = [s for s in dict.fromkeys(states) if s not in self._queued]
        self._queued.update(new)
        self._bar.total += len(new)
        todo = [s for s in new if s not in self.labels]
        self._bar.update(len(new) - len(todo))
        chunk = max(1, min(25, len(todo) // (4 * max(1, self.cfg.workers))))
        for lo in range(0, len(todo), chunk):
            self._pending.append(self.pool.apply_async(_label_chunk, (todo[lo : lo + chunk],)))
            self.poll()  # in one process the chunk has run already: take it, and checkpoint when due

    def collect(self, stream: int, n: int, cache: Path, exclude: frozenset):
        """Start collecting n prepared states of one stream; a job whose get() returns them."""
        return self.pool.apply_async(_collect_stream, (stream, n, cache, exclude))

    def poll(self) -> None:
        """Take the finished label jobs."""
        ready = [j.ready() for j in self._pending]  # asked once: a job may finish meanwhile
        done = [j for j, r in zip(self._pending, ready) if r]
        self._pending = [j for j, r in zip(self._pending, ready) if not r]
        for job in done:
            for state, value, costs, seconds, complete in job.get():
                if not complete:
                    raise DomainError(f"state {state}", f"labelling stopped by the {self.cfg.label_time_limit}s limit")
                self.labels[state] = (value, costs, seconds)
                self._bar.update(1)
        if time.monotonic() - self._last_save > CHECKPOINT_SECONDS:
            self.save()

    def wait(self, jobs=()) -> None:
        """Poll until every label job and every job in `jobs` is done."""
        while self._pending or not all(j.ready() for j in jobs):
            self.poll()
            time.sleep(0.05)
        self.poll()


def read_labels(path: Path) -> tuple[dict, dict]:
    """({state: (c_ap, costs, seconds)}, the file's content) of a label checkpoint (labels.partial.json);
    anything but a JSON object with a table of such labels is a one-line DomainError."""
    try:
        saved = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise DomainError(
            path, f"corrupt checkpoint: {getattr(e, 'msg', type(e).__name__)}; delete it to label again"
        ) from None
    if not isinstance(saved, dict) or not isinstance(saved.get("labels"), dict):
        raise DomainError(
            path,
            f"corrupt checkpoint: {type(saved).__name__} {_short(saved)}, not a JSON object "
            "with a labels table; delete it to label again",
        )
    labels = {}
    for s, v in saved["labels"].items():
        try:
            value, costs, seconds = v
            labels[int(s)] = (float(value), [int(c) for c in costs], float(seconds))
        except (TypeError, ValueError):
            raise DomainError(
                path,
                f"corrupt checkpoint: the label of state {s} is {_short(v)}, not [C_AP, "
                "costs, seconds]; delete it to label again",
            ) from None
    return labels, saved


def _short(value) -> str:
    text = json.dumps(value)
    return text if len(text) <= 40 else text[:37] + "..."


def label_states(
    states: list[int], cfg: DatasetConfig, checkpoint: Path, known: dict | None = None, progress: bool = True
) -> dict:
    """{state: (c_ap, costs, seconds)} for every state, in cfg.workers processes, checkpointed atomically."""
    with Workers(cfg, checkpoint, known, progress) as work:
        work.label(states)
        work.wait()
        return {s: work.labels[s] for s in states}


# ---- the dataset on disk -----------------------------------------------------------------
def dataset_class():
    """LabelledStates: the torch-geometric InMemoryDataset of a gnn_dataset folder."""
    from torch_geometric.data import InMemoryDataset

    class LabelledStates(InMemoryDataset):
        """Graphs with y = C_AP and costs = the per-task optimal costs; `meta` holds the rest."""

        def __init__(self, root):
            super().__init__(str(root), log=False)
            self.load(self.processed_paths[0])
            self.meta = read_meta(root)

        def _process(self):
            """Only check processed/data.pt is there: torch_geometric's own step would torch.load a
            processed/pre_transform.pt or pre_filter.pt with weights_only=False (we write neither)."""
            if not (Path(self.processed_dir) / "data.pt").is_file():
                self.process()

        def load(self, path, data_cls=None):
            """InMemoryDataset.load with weights_only=True and no fallback: torch_geometric's own
            loader retries a refused file with weights_only=False, which would run its code."""
            from torch_geometric.data import Data

            from learning.plain import load_plain

            out = load_plain(path, "gnn dataset")
            if not isinstance(out, tuple) or len(out) not in (2, 3):
                raise DomainError(path, "not a gnn_dataset data.pt (a (data, slices[, class]) tuple expected)")
            data, self.slices = out[0], out[1]
            cls = out[2] if len(out) == 3 else (data_cls or Data)
            self.data = cls.from_dict(data) if isinstance(data, dict) else data

        @property
        def raw_file_names(self):
            return []

        @property
        def processed_file_names(self):
            return ["data.pt"]

        def download(self):
            pass

        def process(self):
            raise DomainError(self.root, "no processed/data.pt: not a gnn_dataset folder")

    return LabelledStates


def read_meta(root) -> dict:
    """A gnn_dataset folder's meta.json; a missing, cut-short or malformed one is a one-line DomainError."""
    path = Path(root) / "meta.json"
    if not path.is_file():
        raise DomainError(root, "not a gnn_dataset folder (no meta.json)")
    try:
        meta = json.loads(path.read_text())
    except (UnicodeDecodeError, json.JSONDecodeError) as e:
        raise DomainError(
            path,
            f"corrupt dataset metadata ({getattr(e, 'msg', 'not text')}: cut short or edited "
            "by hand); build the dataset again (learning.gnn_dataset)",
        ) from None
    except OSError as e:
        raise DomainError(path, f"cannot read: {e.strerror}") from None
    if not isinstance(meta, dict):
        raise DomainError(path, "corrupt dataset metadata (not a JSON object); build the dataset again")
    return meta


def load_dataset(root):
    """The dataset of a gnn_dataset folder (a DomainError if it is missing or unreadable)."""
    root = Path(root)
    if not (root / "meta.json").is_file() or not (root / "processed" / "data.pt").is_file():
        raise DomainError(root, "not a gnn_dataset folder (meta.json and processed/data.pt expected)")
    return dataset_class()(root)


def save_dataset(root, model, states: list[int], labels: dict, meta: dict, encoder=None) -> Path:
    """Write graphs and labels (processed/data.pt) and meta.json into root, each atomically."""
    import torch
    from torch_geometric.data import InMemoryDataset

    from learning.gnn.graph import GraphEncoder

    root = Path(root)
    encoder = encoder or GraphEncoder(model)
    data = []
    for i, s in enumerate(states):
        c_ap, costs, _ = labels[s]
        data.append(
            encoder.encode(
                s, y=torch.tensor([c_ap], dtype=torch.float32), costs=torch.tensor([costs], dtype=torch.int64), index=i
            )
        )
    out = root / "processed" / "data.pt"
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(".data.pt.tmp")
    InMemoryDataset.save(data, str(tmp))
    os.replace(tmp, out)
    meta = {
        **meta,
        **identity(model),
        "layout": model.layout,
        "n": len(states),
        "tasks": [{"task": t.name, "probability": t.probability} for t in model.tasks],
        "node_names": encoder.node_names,
        "node_types": encoder.node_types,
        "feature_names": encoder.feature_names,
        "relation_names": encoder.relation_names,
        "c_ap": [labels[s][0] for s in states],
        "label_seconds": [round(labels[s][2], 4) for s in states],
        "atoms": [[atom_text(k) for k in model.true_atoms(s)] for s in states],
    }
    write_json(root / "meta.json", meta)
    return root


def known_labels(folders, model=None) -> dict:
    """Labels already computed in other gnn_dataset folders (their labels.partial.json), by state.

    A state is a number only within its layout and its labels hold only for the domain content they were
    computed from: labels of another domain, layout or content (the checkpoint's record, else the folder's
    meta.json) are a one-line error naming the file."""
    known = {}
    for folder in folders or []:
        path = Path(folder) / "labels.partial.json"
        if not path.is_file():
            raise DomainError(path, "missing: --reuse-labels names a gnn_dataset folder")
        labels, saved = read_labels(path)
        if model is not None:
            made = saved if "layout" in saved else (read_meta(folder) if (Path(folder) / "meta.json").is_file() else {})
            where = path if "layout" in saved else Path(folder) / "meta.json"
            if made.get("domain") not in (None, model.name) or made.get("layout") not in (None, model.layout):
                raise DomainError(
                    where,
                    f"labels of {made.get('domain')} {made.get('layout')}, not of {model.name} "
                    f"{model.layout}; leave out --reuse-labels {folder}",
                )
            diff = mismatch(made, model)
            if diff is not None:
                raise DomainError(
                    where, f"labels made from {diff}: not this content's C_AP; leave out --reuse-labels {folder}"
                )
        known.update(labels)
    return known


def default_out(model, augmented: bool) -> Path:
    """The dataset folder a build writes unless told otherwise: runs/gnn/DOMAIN-LAYOUT-KIND."""
    return Path("runs/gnn") / f"{model.name}-{model.layout}-{'augmented' if augmented else 'faithful'}"


def check_replaceable(out: Path, cfg: DatasetConfig, model) -> None:
    """A one-line error if `out` holds a finished dataset (its meta.json) that this build would not make
    again: of another domain, layout or domain content, or of other settings (CONTENT_KEYS)."""
    if not (out / "meta.json").is_file():
        return
    meta = read_meta(out)
    where = out / "meta.json"
    then = meta.get("config") if isinstance(meta.get("config"), dict) else {}
    if (meta.get("domain"), meta.get("layout")) != (model.name, model.layout):
        what = f"{meta.get('domain')} {meta.get('layout')}, not {model.name} {model.layout}"
    elif mismatch(meta, model) is not None:
        what = mismatch(meta, model)
    else:
        now = asdict(cfg)
        diff = [f"{k} {then.get(k)!r} there, {now[k]!r} here" for k in CONTENT_KEYS if then.get(k) != now[k]]
        if not diff:
            return
        what = "other settings (" + ", ".join(diff) + ")"
    raise DomainError(where, f"a finished dataset of {what}; pass --force to replace it, or --out another folder")


def build(cfg: DatasetConfig, out, progress: bool = True, reuse=(), force: bool = False) -> dict:
    """Collect, label and save the dataset; returns the metadata written. `reuse`: folders whose labels to take.

    The prepared states come from cfg.prepared_streams independent streams, collected in the
    worker processes while the states found so far are labelled beside them. A finished dataset
    in `out` that this configuration would not make again is a one-line error unless `force`;
    with it, its meta.json goes first, so that the folder reads as unfinished until the new one is
    written. One process writes `out` at a time."""
    from planning.domain.compiler import compile_domain

    out = Path(out)
    model = compile_domain(cfg.domain, cfg.layout)
    cli.check_writable(out, folder=True)
    out.mkdir(parents=True, exist_ok=True)
    with OutputLock(out, "dataset"):
        if force:
            forget_finished(out, model)
        check_replaceable(out, cfg, model)
        return _build(cfg, out, model, progress, reuse)


def forget_finished(out: Path, model) -> None:
    """What --force drops of a finished dataset: its meta.json, and its label checkpoint too where that
    records no layout (written before checkpoints did) and the dataset was of another layout or content,
    whose state numbers would otherwise be read as this layout's."""
    if not (out / "meta.json").is_file():
        return
    try:
        meta = read_meta(out)
    except DomainError:
        meta = {}
    checkpoint = out / "labels.partial.json"
    if checkpoint.is_file():
        try:
            saved = read_labels(checkpoint)[1]
        except DomainError:
            saved = {"layout": None}  # corrupt: Workers says so
        other = (meta.get("domain"), meta.get("layout")) != (model.name, model.layout) or mismatch(meta, model)
        if "layout" not in saved and other:
            checkpoint.unlink()
    (out / "meta.json").unlink()


def _build(cfg: DatasetConfig, out: Path, model, progress: bool, reuse) -> dict:
    t0 = time.perf_counter()
    states = faithful_states(model, cfg.n_states, cfg.seed, progress)
    kinds = ["faithful"] * len(states)
    t_states = time.perf_counter() - t0
    with Workers(cfg, out / "labels.partial.json", known_labels(reuse, model), progress) as work:
        if cfg.augmented:
            n_prep = cfg.n_prepared if cfg.n_prepared is not None else 3 * cfg.n_states
            extra = _prepared(work, cfg, n_prep, states, out, progress)
            states += extra
            kinds += ["prepared"] * len(extra)
        work.label(states)
        work.wait()
        labels = {s: work.labels[s] for s in states}
    t_all = time.perf_counter() - t0
    meta = {
        "config": asdict(cfg),
        "kinds": kinds,
        "seconds_faithful_states": round(t_states, 1),
        "seconds_collecting_and_labelling": round(t_all - t_states, 1),
        "label_cpu_seconds": round(sum(v[2] for v in labels.values()), 1),
    }
    save_dataset(out, model, states, labels, meta)
    return meta


def _prepared(work: Workers, cfg: DatasetConfig, n: int, faithful: list[int], out: Path, progress: bool) -> list[int]:
    """n prepared states, none faithful, from cfg.prepared_streams streams (n / streams each, topped
    up where streams share states). The long stream jobs go to the workers first, the faithful
    states' labels behind them, and each stream's states are queued for labelling when it is done."""
    k = cfg.prepared_streams
    exclude = frozenset(faithful)
    quota = [n // k + (i < n % k) for i in range(k)]
    bar = tqdm(total=n, desc="prepared states", unit="state", disable=not progress)
    while True:
        work.counter.value = 0
        bar.reset()
        jobs = [work.collect(i, quota[i], out / f"prepared-rollout-{i}.json", exclude) for i in range(k)]
        work.label(faithful)
        found: list = [None] * k
        while any(f is None for f in found):
            for i, job in enumerate(jobs):
                if found[i] is None and job.ready():
                    found[i] = job.get()
                    work.label(found[i])
            work.poll()
            bar.update(max(0, min(n, work.counter.value) - bar.n))
            time.sleep(0.05)
        states = list(dict.fromkeys(s for f in found for s in f))
        if len(states) >= n:
            bar.close()
            return states[:n]
        short = n - len(states)
        quota = [q + short // k + 1 for q in quota]  # streams replay their cached plans first

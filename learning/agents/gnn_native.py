"""The one-task GNN baseline with prior work's own selection rule (thesis §5.2.2 item 3; Talukder et al. 2024).

Per task, the candidates are
  * the myopic optimal plan (our exact A* by default), cut at the first state where the task holds;
  * up to `max_clauses` (10) plans that solve the task together with one preparatory clause, planned
    optimally (task AND clause). Which clauses, the *candidate generator*:
      - a domain whose domain.toml declares `[gnn.candidates]` (the restaurant does): the *focused*
        generator of `learning.gnn.candidates`, prior work's own (`_generate_focused_augmentations`
        of the authors' evaluation): the region is the locations on the myopic plan's path plus those
        within the table's hops of the base hop (the smallest move cost), the relevant objects those
        the plan names, those in the region and the declared used-up resources, and the clauses the
        table's families give over them in sorted object order; the first `max_clauses` are planned,
        with no cost sort (the table's `max_clauses` unless --max-clauses says otherwise);
      - a domain without the table: the clause library of the dataset generator
        (`learning.gnn.dataset.ClauseLibrary`: an object clean, a container filled, the jar brought to
        where water is used, the machine water restored), among the clauses false now and costing at
        least the library's minimum (h_max) whose places all lie in the candidate region: the
        locations the agent stands at along the myopic plan plus those one move away. A clause's places
        are the locations it names and, for every object it names, where that object is now (through
        containers; a held object is where the agent is). The clauses are tried cheapest first (h_max),
        then in library order. (On the restaurant every location is one move from every other, so this
        region is the whole map and the cut at 10 drops the clauses that need a fill: the reason the
        restaurant declares the focused generator.)
The augmented candidates are planned by one A* (the minimum over their goals of an admissible heuristic,
`planning.search.optimal.optimal_plans`), by default with the larger of the pattern databases' estimate and
LM-cut's (`learning.gnn.candidates.JOINT_HEURISTIC`, as the dataset's clauses); `--joint-heuristic pdb` takes
the pattern databases alone: the same costs, in a fraction of the time where the plans are long (four
three-room candidate sets of sequence 0: 82.7 s in all against more than 225 s, one search of which ran out
of its time), and another optimal plan where several tie. Results files and the candidate cache record it.
Each candidate is scored by its cost plus the model's Ĉ_AP of its post-consumption end state (one
batched forward pass for all of them; γ = 1); the lowest score wins, and the myopic plan is kept unless
another scores strictly lower (the authors' loop: an augmented candidate replaces the incumbent only
on strict improvement). The configuration a results file records names the generator
(`candidate_generator`).

Augmented candidates are executed and charged in full. The runner stops a plan where the task
first holds, so a candidate is kept only if the task first holds at its last action: an optimal
joint plan that completes the task earlier is replaced by the clause's optimal plan followed by
the task's optimal plan from there, kept if that completes the task only at its end with the
clause still true; otherwise (or if longer than the task's action budget) the candidate is
dropped and counted in the row (`dropped`).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from learning.agents.greedy import checkpoint_run_name
from learning.gnn.candidates import JOINT_HEURISTIC, FocusedCandidates, Region, actions_along
from learning.gnn.value import GNNValue, model_summary
from planning.errors import DomainError
from planning.world.agents import Planner, Reply

JOINT_HEURISTICS = (JOINT_HEURISTIC, "pdb", "lmcut")
"""`--joint-heuristic`: admissible heuristics of the augmented candidates' searches (`planning.heuristics`)."""
GENERATORS = ("domain", "clause-library")
"""`--generator`: the domain's declared candidates, or the dataset's clause library regardless."""
MAX_CLAUSES = 10
TIME_LIMIT = 300.0  # seconds per search: a guard; on this machine every search ends well within it


def select(costs, estimates) -> int:
    """Index of the lowest cost + Ĉ_AP; candidate 0 (the myopic plan) unless another is strictly lower."""
    scores = np.asarray(costs, dtype=float) + np.asarray(estimates, dtype=float)
    best = 0
    for i in range(1, len(scores)):
        if scores[i] < scores[best]:
            best = i
    return best


def candidate_accuracy(per_task: list) -> dict | None:
    """How the estimate did on the candidates it scored, from an evaluation's per-task rows run with
    --exact-labels: MAE and Spearman over all candidates, the share of within-task pairs (different exact
    C_AP) ordered right, the share of tasks where cost + exact C_AP picks the same candidate, and the mean
    excess of the chosen candidate's cost + exact C_AP over the best one's (the price of the estimate's
    errors, in PDDL units, on the next task); and what the rule could gain with exact labels: the share of
    tasks where cost + exact C_AP leaves the myopic plan, and the mean of the myopic plan's cost + exact
    C_AP minus the best candidate's (per scored task). None if no row has exact labels."""
    from scipy import stats

    from learning.gnn.bench import pair_agreement

    rows = [r for r in per_task if r.get("c_ap_exact") and len(r["c_ap_exact"]) == len(r.get("c_ap_hat", ()))]
    if not rows:
        return None
    est = np.concatenate([r["c_ap_hat"] for r in rows])
    exact = np.concatenate([r["c_ap_exact"] for r in rows])
    pairs, same, excess, departs, gain = [], 0, [], 0, []
    for r in rows:
        e, x, c = (np.asarray(r[k], dtype=float) for k in ("c_ap_hat", "c_ap_exact", "candidate_costs"))
        if len(x) > 1 and len(set(x)) > 1:
            pairs.append(pair_agreement(e, x))
        chosen, ideal = select(c, e), select(c, x)
        same += chosen == ideal
        excess.append(c[chosen] + x[chosen] - c[ideal] - x[ideal])
        departs += ideal != 0
        gain.append(c[0] + x[0] - c[ideal] - x[ideal])
    return {
        "tasks": len(rows),
        "candidates": int(len(est)),
        "mae": round(float(np.mean(np.abs(est - exact))), 2),
        "spearman": round(float(stats.spearmanr(est, exact)[0]), 4),
        "within_task_pairs_right": round(float(np.mean(pairs)), 4) if pairs else None,
        "same_choice_as_exact": round(same / len(rows), 4),
        "mean_excess": round(float(np.mean(excess)), 2),
        "exact_departs": round(departs / len(rows), 4),
        "exact_gain": round(float(np.mean(gain)), 2),
    }


class ClauseGoal:
    """One clause as a goal for optimal_plan (a one-binding DNF)."""

    def __init__(self, pos: int, neg: int, name: str = "clause"):
        from planning.domain.model import Op

        self.name = name
        self.bindings = (Op(pos, neg, 0, 0),)

    def satisfied(self, state: int) -> bool:
        o = self.bindings[0]
        return state & o.pos == o.pos and not state & o.neg


class CandidateCache:
    """The candidate plans of each (state, task), kept on disk and shared by every run that plans them alike.

    The candidates depend on the state, the task, the myopic planner and the clause settings, never on
    the model that scores them: the four seeds of a model, faithful or augmented, meet the same states
    for long stretches (they mostly keep the myopic plan), so every run after the first replays most
    of its planning. One JSON line per entry, appended in one write (runs in parallel can share a file:
    on a miss the lines other runs appended since are read first, so two seeds played in opposite
    orders of the sequences, `--sequences 9,8,...,0`, each replay what the other planned; an
    interrupted write leaves at most a half last line, which is skipped); the first line names the
    domain's identity (`planning.domain.identity`: the content of its files, not their comments or
    layout) and the settings, and a file of another domain or settings is a one-line error.
    Only candidates whose searches all finished are kept (a time limit's answer is not the planner's).
    """

    FORMAT = 2

    def __init__(self, model, path, settings: dict):
        from planning.domain.identity import identity

        self.model, self.path = model, Path(path)
        self.header = {"format": self.FORMAT, **identity(model), "layout": model.layout, **settings}
        self.table: dict = {}
        self.hits = self.misses = 0
        self.offset, self.line = 0, 1  # the bytes read so far, and the number of the next line
        if self.path.is_file():
            self._load()
        else:
            self._append(self.header)
            self.offset, self.line = self.path.stat().st_size, 2

    def _load(self) -> None:
        data = self.path.read_bytes()
        first, _, _ = data.partition(b"\n")
        try:
            header = json.loads(first)
        except json.JSONDecodeError:
            raise DomainError(
                self.path, "not a candidate cache (its first line is not JSON); delete it to replan"
            ) from None
        if header != self.header:
            diff = sorted(k for k in {*header, *self.header} if header.get(k) != self.header.get(k))
            raise DomainError(
                self.path,
                f"made for another domain or settings ({', '.join(diff)} differ); "
                "delete it or pass another --candidates",
            )
        self.offset, self.line = len(first) + 1, 2
        self._read(data[self.offset :], at_load=True)

    def _read(self, data: bytes, at_load: bool = False) -> None:
        """The entries of the complete lines of `data` (the file from `offset` on) into the table. A last line
        without its newline is left for later (a run in parallel may be writing it); at load, one that does
        not parse is a write cut short by an interruption: skipped, and planned again."""
        end = data.rfind(b"\n") + 1
        lines = data[:end].split(b"\n")[:-1]
        tail = data[end:]
        for line in lines:
            self._entry(line, self.line)
            self.line += 1
        self.offset += end
        if at_load and tail.strip():
            try:
                self._entry(tail, self.line)
            except DomainError:
                pass
            self.offset += len(tail)

    def _entry(self, line: bytes, n: int) -> None:
        """Line n of the file (raw bytes: a corrupt one is a one-line error, like any bad entry) into the table."""
        if not line.strip():
            return
        try:
            e = json.loads(line)
            plans = [[self.model.action(a) for a in p] for _, p in e["plans"]]
            self.table[(int(e["state"], 16), e["task"])] = (
                [c for c, _ in e["plans"]],
                plans,
                int(e["dropped"]),
                int(e["in_region"]),
            )
        except (json.JSONDecodeError, KeyError, TypeError, ValueError, UnicodeDecodeError) as err:
            raise DomainError(
                self.path, f"line {n} is not a candidate entry ({err}); delete the file to replan"
            ) from None

    def _refresh(self) -> None:
        """The entries runs in parallel appended since this one last read the file."""
        try:
            with open(self.path, "rb") as f:
                f.seek(self.offset)
                data = f.read()
        except OSError:
            return
        if data:
            self._read(data)

    def _append(self, entry: dict) -> None:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o666)
        try:
            os.write(fd, (json.dumps(entry, separators=(",", ":")) + "\n").encode())
        finally:
            os.close(fd)

    def get(self, state: int, task):
        """(names, plans, dropped, in region) of the candidates, or None if never planned (here or by a run in
        parallel)."""
        hit = self.table.get((state, task.name))
        if hit is None:
            self._refresh()
            hit = self.table.get((state, task.name))
        self.hits += hit is not None
        self.misses += hit is None
        return hit

    def put(self, state: int, task, names: list, plans: list, dropped: int, in_region: int) -> None:
        self.table[(state, task.name)] = (names, plans, dropped, in_region)
        actions = self.model.actions
        self._append(
            {
                "state": format(state, "x"),
                "task": task.name,
                "dropped": dropped,
                "in_region": in_region,
                "plans": [[c, [actions[a] for a in p]] for c, p in zip(names, plans)],
            }
        )


class GNNNativePlanner(Planner):
    """The GNN's Ĉ_AP scoring the myopic plan and up to 10 clause-augmented plans: cost + Ĉ_AP, lowest wins."""

    name = "gnn-native"

    @classmethod
    def options(cls, p) -> None:
        from oracles.myopic import PLANNERS

        p.add_argument("--model", required=True, help="GNN checkpoint (learning.gnn_train's best.pt)")
        p.add_argument(
            "--max-clauses",
            type=int,
            default=None,
            help="augmented candidates per task (default: [gnn.candidates] max_clauses, else %s)" % MAX_CLAUSES,
        )
        p.add_argument(
            "--reference",
            default="internal",
            choices=PLANNERS,
            help="planner of the myopic candidate (default: %(default)s, exact)",
        )
        p.add_argument(
            "--time-limit",
            type=float,
            default=TIME_LIMIT,
            help="seconds per search: the myopic plan, or all the augmented ones together (default: %(default)s)",
        )
        p.add_argument(
            "--candidates",
            default=None,
            help="the candidate cache file, shared by runs that plan alike (default: "
            "runs/gnn/candidates/DOMAIN-LAYOUT-REFERENCE[-focused]-cMAX.jsonl; 'none': plan every task)",
        )
        p.add_argument(
            "--generator",
            default="domain",
            choices=GENERATORS,
            help="the candidates: the domain's [gnn.candidates] (default; the clause library where it "
            "declares none), or the clause library whatever the domain declares (the runs made "
            "before the focused generator; their results end in -clause-library)",
        )
        p.add_argument(
            "--exact-labels",
            action="store_true",
            help="also label every scored candidate with the exact C_AP (oracles.labelling), for the record",
        )
        p.add_argument(
            "--joint-heuristic",
            default=JOINT_HEURISTIC,
            choices=JOINT_HEURISTICS,
            help="the admissible heuristic of the augmented candidates' searches: the same costs, other "
            "optimal plans where several tie (default: %(default)s; see the module)",
        )

    @classmethod
    def from_args(cls, args, model) -> "GNNNativePlanner":
        return cls(
            model,
            args.model,
            args.max_clauses,
            args.reference,
            args.time_limit,
            args.exact_labels,
            candidates=args.candidates,
            generator=getattr(args, "generator", "domain"),
            joint_heuristic=getattr(args, "joint_heuristic", JOINT_HEURISTIC),
        )

    def __init__(
        self,
        model,
        gnn,
        max_clauses: int | None = None,
        reference: str = "internal",
        time_limit: float = TIME_LIMIT,
        exact_labels: bool = False,
        estimate=None,
        candidates: str | None = "none",
        generator: str = "domain",
        joint_heuristic: str = JOINT_HEURISTIC,
    ):
        """`estimate(states) -> Ĉ_AP array`: the scorer (default: the checkpoint's GNNValue.c_ap).
        `max_clauses`: None for the domain's [gnn.candidates] max_clauses (else MAX_CLAUSES).
        `candidates`: the CandidateCache file (None: the default one; "none": no cache)."""
        from learning.gnn.dataset import ClauseLibrary, DatasetConfig
        from oracles.myopic import MyopicOracle

        if generator not in GENERATORS:
            raise DomainError("--generator", f"'{generator}' is not one of {', '.join(GENERATORS)}")
        if joint_heuristic not in JOINT_HEURISTICS:
            raise DomainError("--joint-heuristic", f"'{joint_heuristic}' is not one of {', '.join(JOINT_HEURISTICS)}")
        self.joint_heuristic = joint_heuristic
        declared = FocusedCandidates.from_model(model)
        self.focused = declared if generator == "domain" else None
        if max_clauses is None:
            max_clauses = self.focused.max_clauses if self.focused is not None else MAX_CLAUSES
        if max_clauses < 0:
            raise DomainError("--max-clauses", f"must be at least 0, not {max_clauses}")
        self.model, self.max_clauses, self.time_limit = model, int(max_clauses), float(time_limit)
        self.estimate = estimate if estimate is not None else GNNValue(gnn, model).c_ap
        self.reference = MyopicOracle(reference, time_limit)
        self.min_cost = DatasetConfig.min_clause_cost
        self.library = ClauseLibrary(model, self.min_cost)
        self.region = Region(model)
        self.max_actions = int(model.config.get("stream", {}).get("max_actions", 64))
        self.exact_labels = exact_labels
        self._labeller = None
        if self.focused is None:
            described = {
                "max_clauses": self.max_clauses,
                "min_clause_cost": self.min_cost,
                "clauses": len(self.library),
                "region": "myopic plan locations + one move",
                "candidate_generator": {
                    "kind": "clause-library",
                    "source": "learning.gnn.dataset.ClauseLibrary (no [gnn.candidates] in domain.toml)",
                    "order": "h_max, then library order",
                },
            }
        else:
            described = {
                "max_clauses": self.max_clauses,
                "region": f"myopic plan locations + those within {self.focused.hops} base hop(s) "
                f"({self.focused.hops * self.focused.base_hop})",
                "candidate_generator": {
                    **self.focused.describe(),
                    "order": "sorted objects, families in order; no cost sort",
                },
            }
        self.config = {
            **(model_summary(gnn) if estimate is None else {"model": str(gnn)}),
            **described,
            "selection": "cost + C_AP estimate, lowest; the myopic plan unless strictly beaten",
            "reference": self.reference.config,
        }
        self.run_name = checkpoint_run_name(self.name, gnn, "gnn-") + (
            "" if reference == "internal" else f"-{reference}"
        )
        if generator == "clause-library" and declared is not None:
            self.config.pop("candidate_generator")  # as every results file made before the focused generator
            self.run_name += "-clause-library"
        from planning.domain.batched import BatchedModel
        from planning.heuristics.hmax import HMax

        self.bm = BatchedModel(model)
        self.hmax = HMax(model, self.bm)
        if self.focused is None:
            settings = {
                "reference": reference,
                "max_clauses": self.max_clauses,
                "min_clause_cost": self.min_cost,
                "clauses": len(self.library),
                "joint_heuristic": joint_heuristic,
            }
        else:
            settings = {
                "reference": reference,
                "max_clauses": self.max_clauses,
                "joint_heuristic": joint_heuristic,
                "generator": self.focused.describe(),
            }
        if candidates is None:
            kind = "" if self.focused is None else "-focused"
            h = "" if joint_heuristic == JOINT_HEURISTIC else f"-{joint_heuristic}"
            candidates = (
                f"runs/gnn/candidates/{model.name}-{model.layout}-{reference}{kind}-c{self.max_clauses}{h}.jsonl"
            )
        self.cache = None if candidates == "none" else CandidateCache(model, candidates, settings)
        self.config["candidates"] = None if self.cache is None else str(self.cache.path)
        self.config["joint_heuristic"] = joint_heuristic

    def start(self, model, sequence) -> None:
        if model is not self.model:
            raise DomainError(model.layout, f"this agent was built for {self.model.name} {self.model.layout}")
        self.reference.start(model, sequence)

    # ---- candidates ---------------------------------------------------------------------------
    def _path(self, state: int, plan: list) -> list[int]:
        path = [state]
        for a in plan:
            path.append(self.model.apply(path[-1], a))
        return path

    def _cost(self, plan: list) -> int:
        return int(sum(self.model.action_cost[a] for a in plan))

    def _first_hold(self, path: list[int], task) -> int | None:
        return next((k for k, s in enumerate(path) if k > 0 and task.satisfied(s)), None)

    def _in_full(self, state: int, plan, task, clause) -> bool:
        """The task first holds at the plan's last action, the clause holds there, within the budget."""
        if plan is None or not plan or len(plan) > self.max_actions:
            return False
        path = self._path(state, plan)
        return self._first_hold(path, task) == len(plan) and clause.satisfied(path[-1])

    def proposed(self, state: int, myopic_path: list[int], plan=None) -> tuple[list, int]:
        """The clauses planned ([ClauseGoal], in order, at most max_clauses) and how many the generator
        proposed. `plan`: the myopic plan's actions (default: recovered from the path)."""
        if self.focused is not None:
            found = self.focused.clauses(
                state, actions_along(self.model, myopic_path) if plan is None else plan, myopic_path
            )
            return [ClauseGoal(c.pos, c.neg, c.text) for c in found[: self.max_clauses]], len(found)
        region = self.region.around(myopic_path)
        eligible = self.library.eligible(state, self.hmax, self.bm, self.min_cost)
        inside = [
            k
            for k in eligible
            if self.region.places(state, [*self.library.clauses[k][0], *self.library.clauses[k][1]]) <= region
        ]
        if inside:
            n = self.model.n_atoms
            lits = [[*self.library.clauses[k][0], *(n + i for i in self.library.clauses[k][1])] for k in inside]
            cost = self.hmax.literal_costs(self.bm.pack([state]), lits)[0]
            relaxed = {k: int(cost[ls].max()) for k, ls in zip(inside, lits)}
            inside.sort(key=lambda k: (relaxed[k], k))
        return [ClauseGoal(*self.library.masks[k], self.library.text(k)) for k in inside[: self.max_clauses]], len(
            inside
        )

    def clause_plans(self, state: int, task, myopic_path: list[int], plan=None) -> tuple[list, int, int, bool]:
        """[(clause text, plan)] of the augmented candidates, how many were dropped, how many clauses
        the generator proposed (before the cap), and whether every search finished (no time limit cut
        one short). `plan`: the myopic plan's actions (default: recovered from the path)."""
        from learning.gnn.dataset import JointGoal
        from planning.search.optimal import optimal_plans

        clauses, proposed = self.proposed(state, myopic_path, plan)
        if not clauses:
            return [], 0, proposed, True
        joint = optimal_plans(
            self.bm,
            state,
            [JointGoal(task, c.bindings[0].pos, c.bindings[0].neg) for c in clauses],
            time_limit=self.time_limit,
            heuristic=self.joint_heuristic,  # one A* for all of them
            prefer=lambda i, plan: self._in_full(state, plan, task, clauses[i]),
        )
        out, dropped, complete = [], 0, all(r.complete for r in joint)
        for clause, r in zip(clauses, joint):
            plan = r.plan
            if plan is not None and not self._in_full(state, plan, task, clause):
                plan, finished = self._clause_then_task(state, task, clause)
                complete = complete and finished
            if plan is None:
                dropped += 1
                continue
            out.append((clause.name, list(plan)))
        return out, dropped, proposed, complete

    def _clause_then_task(self, state: int, task, clause) -> tuple[list | None, bool]:
        """The clause's optimal plan, then the task's from there (for a joint plan that completes the
        task early), if the runner executes it in full; and whether both searches finished."""
        from planning.search.optimal import optimal_plan

        first = optimal_plan(self.bm, state, clause, time_limit=self.time_limit, heuristic=self.joint_heuristic)
        if not first.plan:
            return None, first.complete
        p1 = self._path(state, first.plan)
        hold = self._first_hold(p1, task)
        if hold is None:
            rest = optimal_plan(self.bm, p1[-1], task, time_limit=self.time_limit)
            if rest.plan is None:
                return None, rest.complete
            plan = list(first.plan) + list(rest.plan)
        else:
            plan = list(first.plan) if hold == len(first.plan) else None
        return (plan if plan is not None and self._in_full(state, plan, task, clause) else None), True

    def candidates(self, state: int, task, upcoming: list):
        """(names, plans, dropped, in region) of a task's candidates, the myopic plan first; or the
        myopic planner's status (a string) when it found no plan."""
        known = self.cache.get(state, task) if self.cache is not None else None
        if known is not None:
            return known
        ref = self.reference.plan(state, task, upcoming)
        if ref.plan is None:
            return ref.info.get("status", "unsolvable")
        path = self._path(state, ref.plan)
        cut = self._first_hold(path, task)
        if cut is None:
            raise DomainError(task.name, "the myopic plan does not complete the task")
        augmented, dropped, in_region, complete = self.clause_plans(state, task, path[: cut + 1])
        names = ["myopic"] + [c for c, _ in augmented]
        plans = [list(ref.plan[:cut])] + [p for _, p in augmented]
        if complete and self.cache is not None:
            self.cache.put(state, task, names, plans, dropped, in_region)
        return names, plans, dropped, in_region

    def plan(self, state: int, task, upcoming: list) -> Reply:
        found = self.candidates(state, task, upcoming)
        if isinstance(found, str):
            return Reply(None, {"status": found})
        names, plans, dropped, in_region = found
        costs = [self._cost(p) for p in plans]
        ends = [task.consume(self._path(state, p)[-1]) for p in plans]
        est = np.asarray(self.estimate(ends), dtype=float)
        best = select(costs, est)
        info = {
            "status": "solved",
            "candidates": len(plans),
            "dropped": dropped,
            "in_region": in_region,
            "chosen": names[best],
            "c_myo": costs[0],
            "cost": costs[best],
            "score": round(float(costs[best] + est[best]), 3),
            "myopic_score": round(float(costs[0] + est[0]), 3),
            "c_ap_hat": [round(float(e), 3) for e in est],
            "candidate_costs": costs,
        }
        if self.exact_labels:
            if self._labeller is None:
                from oracles.labelling import Labeller

                self._labeller = Labeller(self.model)
            info["c_ap_exact"] = [round(float(self._labeller.label(s).c_ap), 3) for s in ends]
        return Reply(plans[best], info)

"""A window of K tasks compiled into one problem: plan them jointly, in order (clairvoyant oracle).

The joint state is the world state plus a one-hot stage (bit n + k: task k is
current; bit n + K: all done). Stage k completes as soon as task k's goal holds,
as in the persistent world: the first satisfied binding's consumption is
applied and the stage advances (a task that then already holds completes too).

Two compilations of the same window:
- `JointSearch`: our exact A*, where completion is a vectorized step applied to
  every generated state, and h is a "window" heuristic of the registry
  (planning.heuristics) of each state's stages left, e.g. the pattern
  databases of the window, or LM-cut of the stage-layered delete relaxation
  (planning.heuristics.layered), which sees that two water tasks need water
  twice, because the first cup's water is consumed, while a filled jar carries
  over.
- `joint_up_problem`: a unified-planning problem Fast Downward accepts, where
  primitive actions are blocked while the current stage's goal holds and
  zero-cost completion actions fire in first-binding order.
"""

from __future__ import annotations

import numpy as np

from planning.domain.batched import BatchedModel
from planning.heuristics import build
from planning.search.cost_levels import CostLevels
from planning.search.optimal import SearchResult
from planning.states import INF_64


class JointSearch:
    """Exact optimal joint plans for windows of tasks of one model."""

    def __init__(self, model, max_window: int = 4):
        self.model = model
        self.n = model.n_atoms
        self.bm = BatchedModel(model, extra_bits=max_window + 1)
        self.max_window = max_window

    def _stage_word(self, k: int) -> tuple[int, np.uint64]:
        bit = self.n + k
        return bit // 64, np.uint64(1) << np.uint64(bit % 64)

    def _stages(self, batch: np.ndarray, K: int) -> np.ndarray:
        """(N,) current stage of each joint state (K: all done)."""
        stage = np.full(len(batch), -1, dtype=np.int64)
        for k in range(K + 1):
            w, b = self._stage_word(k)
            stage[(batch[:, w] & b) != 0] = k
        return stage

    def _complete(self, batch: np.ndarray, tasks: list) -> np.ndarray:
        """Complete every stage whose goal holds, in order, with consumption (vectorized)."""
        batch = batch.copy()
        for k, task in enumerate(tasks):
            w, b = self._stage_word(k)
            rows = np.flatnonzero((batch[:, w] & b) != 0)
            if not len(rows):
                continue
            sub = batch[rows]
            pending = np.ones(len(rows), dtype=bool)
            for op in task.bindings:  # the first satisfied binding consumes
                pos, neg = self.bm.pack([op.pos])[0], self.bm.pack([op.neg])[0]
                hold = pending & ((sub & pos) == pos).all(1) & ((sub & neg) == 0).all(1)
                if hold.any():
                    sub[hold] = self.bm.apply_op(sub[hold], op)
                    pending &= ~hold
            done = ~pending
            sub[done, w] &= ~b
            w2, b2 = self._stage_word(k + 1)
            sub[done, w2] |= b2
            batch[rows] = sub
        return batch

    def plan(
        self,
        state: int,
        tasks: list,
        max_states: int | None = None,
        time_limit: float | None = None,
        heuristic: str = "pdb",
        weight: int = 1,
    ) -> SearchResult:
        """An optimal plan that completes the tasks in order from a world state.

        heuristic: a name of the registry's "window" rows (planning.heuristics), each state scored on
        the tasks of its stages left: "pdb" (the larger of the current task's pattern databases and the
        window's, planning.heuristics.pdb, which see the round trips and the one hand that relaxations
        miss; the window's follow the stages left through their goals and consumptions; LM-cut is left
        out: on three-task windows it took 88% of the time and solved fewer), "layered" (LM-cut of the
        stages left), "lmcut" or "hmax" (of the current stage).
        weight > 1: weighted A* (f = g + weight * h), a plan at most `weight` times the optimal
        cost; lower_bound is then the last f-level / weight. With weight 1 an interrupted
        search still proves lower_bound <= the optimal cost (the clairvoyant's bounded windows).
        """
        stages_left = build(heuristic, self.bm, "window")
        K = len(tasks)
        if K > self.max_window:
            raise ValueError(f"window of {K} tasks, built for at most {self.max_window}")
        start = self._complete(self.bm.pack([state | (1 << self.n)]), tasks)

        def h(batch):
            stage = self._stages(batch, K)
            out = np.zeros(len(batch), dtype=np.int64)
            for k in range(K):
                sel = stage == k
                if not sel.any():
                    continue
                out[sel] = stages_left(batch[sel], tasks[k:])
            return np.where(out >= INF_64, INF_64, out * weight)

        levels = CostLevels(
            self.bm,
            self.bm.unpack(start)[0],
            max_states,
            time_limit,
            heuristic=h,
            after_step=lambda b: self._complete(b, tasks),
            building=getattr(stages_left, "building", None),
        )
        w, b = self._stage_word(K)
        for _, rows, ids, g in levels:
            hit = np.flatnonzero((rows[:, w] & b) != 0)
            if len(hit):
                i = hit[np.argmin(g[hit])]
                return SearchResult(levels.plan_to(int(ids[i])), int(g[i]), levels.closed, True, -(-levels.f // weight))
        return SearchResult(None, None, levels.closed, levels.exhausted, -(-levels.f // weight))


def joint_up_problem(model, state: int, tasks: list):
    """The window as a unified-planning problem (stage fluents, blocked actions, completions)."""
    from unified_planning.model.metrics import MinimizeActionCosts
    from unified_planning.shortcuts import And, BoolType, Fluent, InstantaneousAction, Not, Or

    from planning.external.pddl_writer import problem_text
    from planning.external.up_bridge import up_problem

    problem = up_problem(model, problem_text(model, state, "(and)"))
    em = problem.environment.expression_manager
    atom = lambda key: problem.fluent(key[0])(*(problem.object(o) for o in key[1:]))
    lits = lambda mask, value: [
        atom(model.atoms[i]) if value else Not(atom(model.atoms[i])) for i in range(mask.bit_length()) if mask >> i & 1
    ]
    conj = lambda op: And(*lits(op.pos, True), *lits(op.neg, False)) if (op.pos or op.neg) else em.TRUE()
    K = len(tasks)
    stages = [Fluent(f"stage-{k}", BoolType()) for k in range(K + 1)]
    for k, f in enumerate(stages):
        problem.add_fluent(f, default_initial_value=(k == 0))
    goals = [Or(*[conj(op) for op in t.bindings]) for t in tasks]
    old = problem.quality_metrics[0]
    costs = dict(old.costs)
    for action in problem.actions:  # a task completes as soon as its goal holds
        for k in range(K):
            action.add_precondition(Or(Not(stages[k]()), Not(goals[k])))
    for k, task in enumerate(tasks):
        for j, op in enumerate(task.bindings):
            act = InstantaneousAction(f"complete-{k}-{j}")
            act.add_precondition(stages[k]())
            act.add_precondition(conj(op))
            for earlier in task.bindings[:j]:
                act.add_precondition(Not(conj(earlier)))
            for key in (model.atoms[i] for i in range(op.dele.bit_length()) if op.dele >> i & 1):
                if not op.add >> model.atom_index[key] & 1:
                    act.add_effect(atom(key), False)
            for key in (model.atoms[i] for i in range(op.add.bit_length()) if op.add >> i & 1):
                act.add_effect(atom(key), True)
            for cp, cn, ca, cd in op.cond:
                cond = And(*lits(cp, True), *lits(cn, False))
                for f in lits(cd, True):
                    act.add_effect(f, False, cond)
                for f in lits(ca, True):
                    act.add_effect(f, True, cond)
            act.add_effect(stages[k](), False)
            act.add_effect(stages[k + 1](), True)
            problem.add_action(act)
            costs[act] = em.Int(0)
    problem.clear_quality_metrics()
    problem.add_quality_metric(MinimizeActionCosts(costs, default=em.Int(0)))
    problem.clear_goals()
    problem.add_goal(stages[K]())
    return problem

"""Task-distribution estimators: what an agent believes the next task's distribution to be.

The thesis's P(τ) enters in two places, the learner's boundary target and the search's terminal
score (V_AP), and the labelling oracle's C_AP in a third; each asks an estimator the same question:

    probabilities(after)  ->  (instances,) P(next task | after, the stream seen so far)

where `after` is the task just completed (None: no task yet, a sequence's start). The estimator
sees the stream through `observe(task)` (each task as it is drawn) and `restart()` (a world reset:
the next task starts a new sequence, so no transition is counted into it). Four are built in
(`ESTIMATORS`, `build`):

- known: the layout's i.i.d. P(τ) of [tasks], the thesis's assumption (default; it ignores what it
  sees, and every result made before estimators existed is this one's);
- empirical: counts of the tasks seen so far plus a prior of `prior` pseudo-counts spread uniformly
  over P's support (so it starts uniform, "from nothing"); with `forget` < 1 every count decays by
  that factor per task seen (a running average weighted towards recent tasks, to track a drift);
- markov: P(τ' | τ) of a declared Markov stream, known (`planning.world.streams`);
- markov-empirical: P(τ' | τ) learned online as a Markov stream declares it: transition counts from
  each task type to the next task's type (each row with empirical's prior, over the types, and its
  forgetting), times each type's arguments as empirical counts them over the whole stream; before
  any task (after = None) the type counts' column sums (the empirical marginal of the next type).

Every distribution is over the layout's task instances and zero off P's support, so the learner's
and the search's sums over the support are unchanged in shape.
"""

from __future__ import annotations

import numpy as np

from planning.errors import DomainError


class Estimator:
    """The protocol (and the known i.i.d. estimator): observe the stream, answer P(next | after)."""

    name = "known"

    def __init__(self, model):
        p = np.asarray(model.tasks.probabilities, dtype=np.float64)
        self.p = p / p.sum()
        self.support = self.p > 0
        self.tasks = model.tasks
        self.type_index = {ty: k for k, ty in enumerate(dict.fromkeys(t.type for t in model.tasks))}
        self.type_of = np.array([self.type_index[t.type] for t in model.tasks], dtype=np.int64)

    def observe(self, task) -> None:
        """One more task of the stream, as it is drawn."""

    def restart(self) -> None:
        """The world was reset: the next task starts a sequence (no transition into it)."""

    def probabilities(self, after=None) -> np.ndarray:
        """(instances,) the next task's distribution after the task `after` (None: at a sequence's start)."""
        return self.p

    def state_dict(self) -> dict:
        """What a checkpoint keeps to resume the estimate."""
        return {"name": self.name}

    def load_state_dict(self, state: dict) -> None:
        if state.get("name") != self.name:
            raise DomainError("estimator", f"a {state.get('name')!r} estimate cannot resume a {self.name!r} one")


class Empirical(Estimator):
    """Counts of the tasks seen, with a uniform prior over the support and optional forgetting."""

    name = "empirical"

    def __init__(self, model, prior: float = 1.0, forget: float = 1.0):
        super().__init__(model)
        if not prior > 0:
            raise DomainError("--prior", f"{prior!r} is not a positive number of pseudo-counts")
        if not 0 < forget <= 1:
            raise DomainError("--forget", f"{forget!r} is not a factor in (0, 1]")
        self.prior, self.forget = float(prior), float(forget)
        self.counts = np.zeros(len(self.p))
        self.base = self.support / self.support.sum() * self.prior

    def observe(self, task) -> None:
        self.counts *= self.forget
        self.counts[task.index] += 1.0

    def probabilities(self, after=None) -> np.ndarray:
        c = self.counts + self.base
        return c / c.sum()

    def state_dict(self) -> dict:
        return {"name": self.name, "counts": self.counts.copy(), "prior": self.prior, "forget": self.forget}

    def load_state_dict(self, state: dict) -> None:
        super().load_state_dict(state)
        self.counts = np.asarray(state["counts"], dtype=np.float64).copy()


class Markov(Estimator):
    """P(τ' | τ) of a declared Markov stream, known."""

    name = "markov"

    def __init__(self, model, stream):
        super().__init__(model)
        if stream is None or stream.kind != "markov":
            kind = "the i.i.d. stream" if stream is None else f"stream {stream.name} ({stream.kind})"
            raise DomainError("--estimator", f"markov needs a Markov stream, not {kind} (pass --stream NAME)")
        self.stream = stream

    def probabilities(self, after=None) -> np.ndarray:
        return self.stream.probabilities(after)


class MarkovEmpirical(Empirical):
    """P(τ' | τ) learned online, factored as a Markov stream is declared: the next type's transition counts from
    the type just done (a row per type, each with `prior` pseudo-counts spread over the types drawn), times
    each type's arguments as counted over the whole stream (`Empirical`'s counts within the type). Forgetting
    decays both. The stream's table is over types and its arguments are drawn as [tasks] draws them, so the
    factoring is the stream's own, and a type-to-type table learns from the few transitions of one sequence
    what a type-to-instance table cannot (the restaurant: 36 cells against 288)."""

    name = "markov-empirical"

    def __init__(self, model, prior: float = 1.0, forget: float = 1.0):
        super().__init__(model, prior, forget)
        k = len(self.type_index)
        drawn = np.bincount(self.type_of, weights=self.support.astype(np.float64), minlength=k) > 0
        self.type_base = drawn / drawn.sum() * self.prior
        self.transitions = np.zeros((k, k))
        self.last = None

    def observe(self, task) -> None:
        super().observe(task)
        if self.last is not None:
            row = self.transitions[self.type_of[self.last.index]]
            row *= self.forget
            row[self.type_of[task.index]] += 1.0
        self.last = task

    def restart(self) -> None:
        self.last = None

    def probabilities(self, after=None) -> np.ndarray:
        t = self.transitions.sum(0) if after is None else self.transitions[self.type_of[after.index]]
        types = (t + self.type_base) / (t + self.type_base).sum()
        c = self.counts + self.base  # zero off the support, and on every instance of a type never drawn
        per_type = np.bincount(self.type_of, weights=c, minlength=len(self.type_base))[self.type_of]
        within = np.divide(c, per_type, out=np.zeros_like(c), where=per_type > 0)
        return types[self.type_of] * within

    def state_dict(self) -> dict:
        return {
            **super().state_dict(),
            "transitions": self.transitions.copy(),
            "last": None if self.last is None else self.last.index,
        }

    def load_state_dict(self, state: dict) -> None:
        super().load_state_dict(state)
        self.transitions = np.asarray(state["transitions"], dtype=np.float64).copy()
        self.last = None if state.get("last") is None else self.tasks[state["last"]]


ESTIMATORS = {"known": Estimator, "empirical": Empirical, "markov": Markov, "markov-empirical": MarkovEmpirical}
"""name -> class; `build` makes one for a layout and stream."""


def build(name: str | None, model, stream=None, prior: float = 1.0, forget: float = 1.0) -> Estimator:
    """The estimator of that name (None: known) for a layout and the stream it will see."""
    name = name or "known"
    if name not in ESTIMATORS:
        raise DomainError("--estimator", f"'{name}' is not an estimator ({', '.join(ESTIMATORS)})")
    if name == "known":
        return Estimator(model)
    if name == "markov":
        return Markov(model, stream)
    return ESTIMATORS[name](model, prior, forget)


def tracking(make, stream, sequences: list) -> dict:
    """How far an estimate is from the stream's own next-task distribution along task sequences, fed as the
    guided agent feeds it (`learning.agents.guided`): a fresh estimator (`make()`) per sequence that has seen
    tasks 0 to p − 1 when it predicts task p. At each position p ≥ 1, the total-variation distance
    ½ Σ |P̂(· | task p − 1) − P(· | task p − 1, p)| between its prediction and the stream's, over task types
    and over task instances (what V_AP sums over). Returns {"types": (n − 1,), "instances": (n − 1,)}: the
    mean over the sequences at positions 1 to n − 1 (n: the shortest sequence's length)."""
    n = min(len(tasks) for tasks in sequences)
    kinds = np.maximum(stream.type_of, 0)
    drawn = stream.type_of >= 0

    def by_type(p: np.ndarray) -> np.ndarray:
        return np.bincount(kinds, weights=np.where(drawn, p, 0.0), minlength=len(stream.types))

    types, instances = np.zeros((len(sequences), n - 1)), np.zeros((len(sequences), n - 1))
    for i, tasks in enumerate(sequences):
        estimator = make()
        for p in range(1, n):
            estimator.observe(tasks[p - 1])
            got, true = estimator.probabilities(tasks[p - 1]), stream.probabilities(tasks[p - 1], p)
            instances[i, p - 1] = 0.5 * np.abs(got - true).sum()
            types[i, p - 1] = 0.5 * np.abs(by_type(got) - by_type(true)).sum()
    return {"types": types.mean(0), "instances": instances.mean(0)}

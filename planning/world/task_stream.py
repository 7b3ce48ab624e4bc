"""The persistent world: tasks one after another, never reset between them.

Rules (thesis Chapter 3, §5.2.3): a task already satisfied when drawn completes
at once with zero cost and zero actions; on success its consumption is applied;
a task not completed within `max_actions` primitive actions is abandoned (its
actions' cost is still charged) and the next starts wherever the world is. The
world is re-sampled from a reset seed every `tasks_per_reset` tasks.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from planning.errors import DomainError


@dataclass
class Outcome:
    """How one task ended."""

    task: str
    cost: int
    actions: int
    success: bool
    auto: bool = False  # already satisfied when drawn


@dataclass
class Step:
    """The result of one primitive action."""

    cost: int
    completed: bool  # the action reached the goal (consumption applied)
    abandoned: bool  # the action used up the budget without reaching it


class PersistentWorld:
    """One world state that persists across tasks, with the current task and its budget."""

    def __init__(self, model, reset_seed: int = 0, max_actions: int | None = None):
        self.model = model
        self.max_actions = max_actions or model.config.get("stream", {}).get("max_actions", 64)
        self.state = model.reset_state(reset_seed)
        self.task = None
        self.outcomes: list[Outcome] = []
        self._cost = self._actions = 0

    def reset(self, seed: int) -> int:
        """Re-sample the world (between sequences), dropping any unfinished task."""
        self.state = self.model.reset_state(seed)
        self.task = None
        return self.state

    def begin(self, task) -> bool:
        """Make `task` current; if it already holds, complete it at zero cost and return True."""
        if self.task is not None:
            raise DomainError(task.name, f"task {self.task.name} is still open")
        self.task, self._cost, self._actions = task, 0, 0
        if task.satisfied(self.state):
            self._finish(success=True, auto=True)
            return True
        return False

    def act(self, action: int) -> Step:
        """Apply one primitive action of the current task (an error, world unchanged, if inapplicable)."""
        if self.task is None:
            raise DomainError(self.model.actions[action], "no open task")
        self.state = self.model.apply(self.state, action)
        cost = self.model.action_cost[action]
        self._cost += cost
        self._actions += 1
        if self.task.satisfied(self.state):
            self._finish(success=True)
            return Step(cost, True, False)
        if self._actions >= self.max_actions:
            self._finish(success=False)
            return Step(cost, False, True)
        return Step(cost, False, False)

    def execute(self, plan: list) -> list:
        """Run a plan for the current task within its budget; the actions executed.

        The plan stops where the task completes or is abandoned; a plan that ends
        short of the goal fails the task.
        """
        for k, a in enumerate(plan):
            step = self.act(a)
            if step.completed or step.abandoned:
                return list(plan[: k + 1])
        self.abandon()
        return list(plan)

    def complete(self, task, plan: list) -> int:
        """Complete `task`, which has just failed, with `plan`, outside its budget (the runner's fallback):
        the actions applied, then, if the goal holds, its consumption. The world is where a finished
        task would leave it. Returns the plan's cost; an error (world unchanged) if it misses the goal."""
        failed = self.outcomes[-1] if self.outcomes else None
        if failed is None or failed.success or self.task is not None or failed.task != task.name:
            raise DomainError(task.name, "only the task that has just failed can be completed")
        state, cost = self.state, 0
        for a in plan:
            state = self.model.apply(state, a)
            cost += self.model.action_cost[a]
        if not task.satisfied(state):
            raise DomainError(failed.task, "the completion plan does not reach its goal")
        self.state = task.consume(state)
        return cost

    def abandon(self) -> None:
        """Give up the current task (e.g. the planner failed): a failure, its cost so far charged."""
        self._finish(success=False)

    def _finish(self, success: bool, auto: bool = False) -> None:
        if success:
            self.state = self.task.consume(self.state)
        self.outcomes.append(Outcome(self.task.name, self._cost, self._actions, success, auto))
        self.task = None


def draw_tasks(model, seed: int, n: int, stream=None) -> list:
    """n tasks drawn with a seeded generator from a stream (`planning.world.streams`; None: i.i.d. from the
    layout's task distribution), positions 0 to n-1 after a reset."""
    rng = np.random.default_rng(seed)
    if stream is None or stream.kind == "iid":
        return [model.tasks.sample(rng) for _ in range(n)]
    out, previous = [], None
    for k in range(n):
        previous = stream.sample(rng, previous, k)
        out.append(previous)
    return out


class TaskStream:
    """An endless seeded stream of (task, world-reset flag) for learning and demonstrations.

    After every `tasks_per_reset` tasks the world is re-sampled; the domain may
    name a fixed first task after each reset ([stream] first_task), as the
    minimal example does (clear C, then a delivery drawn from P). `stream` is the
    declared stream the tasks follow (`planning.world.streams`; None: i.i.d. from P);
    a Markov stream conditions each task on the one before within a reset period,
    a drifting one on the position in it.
    """

    def __init__(self, model, seed: int, stream=None):
        config = model.config.get("stream", {})
        self.model = model
        self.rng = np.random.default_rng(seed)
        self.tasks_per_reset = config.get("tasks_per_reset", 50)
        first = config.get("first_task")
        self.first_task = model.tasks.get(first) if first else None
        self.stream = stream
        self.count = 0
        self.previous = None

    def next(self) -> tuple:
        """(task, reset_seed or None): a reset seed when the world must be re-sampled first."""
        k = self.count % self.tasks_per_reset
        reset = int(self.rng.integers(2**31)) if k == 0 else None
        if k == 0 and self.first_task:
            task = self.first_task
        elif self.stream is None or self.stream.kind == "iid":
            task = self.model.tasks.sample(self.rng)
        else:
            task = self.stream.sample(self.rng, None if k == 0 else self.previous, k)
        self.count += 1
        self.previous = task
        return task, reset

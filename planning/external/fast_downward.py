"""Fast Downward, through unified-planning and up-fast-downward, on one task from one state.

Results carry named codes in the style of Fast Downward's driver; a returned
plan is mapped onto our ground actions and validated by replay in our simulator.
A domain with derived predicates, which unified-planning cannot represent, is
written out as PDDL with its `:derived` axioms (planning.external.pddl_writer) and
given to up-fast-downward's own Fast Downward driver directly, so its translator
and search evaluate the axioms themselves.
"""

from __future__ import annotations

import contextlib
import importlib.resources
import os
import re
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from enum import Enum
from pathlib import Path

from planning.errors import DomainError
from planning.external.pddl_writer import domain_text, problem_text, task_goal_text
from planning.external.up_bridge import action_name, up, up_goal_text, up_problem, up_problem_text

OPTIMAL_CONFIG = "astar(blind())"  # the thesis's myopic oracle: A* with the blind heuristic


class Status(Enum):
    SOLVED = "solved"
    UNSOLVABLE = "unsolvable"
    OUT_OF_TIME = "out-of-time"
    OUT_OF_MEMORY = "out-of-memory"
    CRASHED = "crashed"


def _status(up_status) -> Status:
    """Our status of a unified-planning plan generation status (anything else: CRASHED)."""
    s = up().engines.PlanGenerationResultStatus
    return {
        s.SOLVED_SATISFICING: Status.SOLVED,
        s.SOLVED_OPTIMALLY: Status.SOLVED,
        s.UNSOLVABLE_PROVEN: Status.UNSOLVABLE,
        s.UNSOLVABLE_INCOMPLETELY: Status.UNSOLVABLE,
        s.TIMEOUT: Status.OUT_OF_TIME,
        s.MEMOUT: Status.OUT_OF_MEMORY,
    }.get(up_status, Status.CRASHED)


@dataclass
class PlanResult:
    status: Status
    plan: list = field(default_factory=list)  # ground action indices of our model
    cost: int | None = None
    optimal: bool = False  # A* with an admissible heuristic, solved
    seconds: float = 0.0
    expansions: int | None = None  # as Fast Downward reports them
    message: str = ""


@contextlib.contextmanager
def _private_cwd():
    # Fast Downward's driver writes its translator output to ./output.sas: two
    # planners sharing a working directory would read each other's tasks.
    old = os.getcwd()
    with tempfile.TemporaryDirectory(prefix="fd-") as d:
        os.chdir(d)
        try:
            yield
        finally:
            os.chdir(old)


def run_planner(problem, search: str = OPTIMAL_CONFIG, time_limit: float = 600.0):
    """Fast Downward on a unified-planning problem: (UP result, the planner's log text)."""
    params = {
        "fast_downward_search_config": search,
        "fast_downward_search_time_limit": f"{max(1, int(time_limit))}s",
        "log_level": "info",
    }
    with _private_cwd(), up().shortcuts.OneshotPlanner(name="fast-downward", params=params) as planner:
        result = planner.solve(problem, timeout=time_limit + 30)
    return result, "\n".join(m.message for m in result.log_messages or [])


# The driver's exit codes (fast-downward.org: exit codes), for a run without unified-planning.
_EXIT = {
    0: Status.SOLVED,
    10: Status.UNSOLVABLE,
    11: Status.UNSOLVABLE,
    12: Status.UNSOLVABLE,
    20: Status.OUT_OF_MEMORY,
    21: Status.OUT_OF_TIME,
    22: Status.OUT_OF_MEMORY,
    23: Status.OUT_OF_TIME,
    24: Status.OUT_OF_MEMORY,
}


def driver() -> Path:
    """up-fast-downward's Fast Downward driver script (fast-downward.py)."""
    return Path(str(importlib.resources.files("up_fast_downward").joinpath("downward/fast-downward.py")))


def run_driver(domain: str, problem: str, search: str = OPTIMAL_CONFIG, time_limit: float = 600.0):
    """Fast Downward on PDDL texts: (status, plan as [(action, [args])] or None, the planner's log text)."""
    with tempfile.TemporaryDirectory(prefix="fd-") as d:
        d = Path(d)
        (d / "domain.pddl").write_text(domain)
        (d / "problem.pddl").write_text(problem)
        cmd = [
            sys.executable,
            str(driver()),
            "--plan-file",
            "plan",
            "--search-time-limit",
            f"{max(1, int(time_limit))}s",
            "domain.pddl",
            "problem.pddl",
            "--search",
            search,
        ]
        try:
            run = subprocess.run(cmd, cwd=d, capture_output=True, text=True, timeout=time_limit + 30)
        except subprocess.TimeoutExpired:
            return Status.OUT_OF_TIME, None, ""
        log = run.stdout + run.stderr
        status = _EXIT.get(run.returncode, Status.CRASHED)
        if status != Status.SOLVED:
            return status, None, log
        plan = []
        for line in (d / "plan").read_text().splitlines():
            line = line.strip()
            if line.startswith("(") and line.endswith(")"):
                name, *args = line[1:-1].split()
                plan.append((name, args))
        return status, plan, log


def solve(model, state: int, task, time_limit: float = 600.0, search: str = OPTIMAL_CONFIG) -> PlanResult:
    """Plan one task from one state with Fast Downward; the plan is replayed in our simulator.

    Through unified-planning (the domain renamed where it needs it), or, for a domain with
    derived predicates, by the driver directly on the domain written with its axioms."""
    start = time.perf_counter()
    if model.source.derived:
        goal = task_goal_text(model, task)
        status, steps, log = run_driver(domain_text(model), problem_text(model, state, goal), search, time_limit)
        seconds = time.perf_counter() - start
        if status != Status.SOLVED:
            tail = " ".join(log.split())[-300:]
            return PlanResult(status, seconds=seconds, message=f"{status.name} {tail}".strip())
        plan = [model.action(f"{name}({', '.join(args)})") for name, args in steps]
    else:
        problem = up_problem(model, up_problem_text(model, state, up_goal_text(model, task)))
        result, log = run_planner(problem, search, time_limit)
        seconds = time.perf_counter() - start
        status = _status(result.status)
        if status != Status.SOLVED:
            tail = " ".join(log.split())[-300:]
            return PlanResult(status, seconds=seconds, message=f"{result.status.name} {tail}".strip())
        plan = [model.action(action_name(a.action, a.actual_parameters, model)) for a in result.plan.actions]
    cost = replay_cost(model, state, plan, task)
    reported = _logged_int(r"Plan cost: (\d+)", log)
    if reported is not None and reported != cost:
        raise DomainError(task.name, f"Fast Downward reports cost {reported}, our replay costs {cost}")
    # unified-planning says SOLVED_SATISFICING even for A*: optimality is ours to record.
    optimal = search.startswith("astar(") and any(h in search for h in ADMISSIBLE)
    return PlanResult(Status.SOLVED, plan, cost, optimal, seconds, _logged_int(r"Expanded (\d+) state", log))


ADMISSIBLE = ("blind()", "lmcut()", "hmax()", "ipdb(", "cegar(", "merge_and_shrink(")


def _logged_int(pattern: str, log: str) -> int | None:
    found = re.findall(pattern, log)
    return int(found[-1]) if found else None


def replay_cost(model, state: int, plan: list[int], task=None) -> int:
    """The cost of a plan replayed in our simulator; an error if a step or the goal fails."""
    cost = 0
    for a in plan:
        state = model.apply(state, a)
        cost += model.action_cost[a]
    if task is not None and not task.satisfied(state):
        raise DomainError(task.name, "the replayed plan does not reach the goal")
    return cost

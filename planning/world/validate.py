"""An independent check of results files: every plan they record, replayed by unified-planning.

    python -m planning.world.validate results/blockworld-clairvoyant-2-grid7x7.json [FILE ...]
    python -m planning.world.validate --all            # every results file under results/
        [--domain DIR]  (a file is read with domains/<the domain it records>, else with DIR)

Per sequence the file played, the world starts from the sequence's reset seed (the domain's
[[reset]] sampling) and the file's rows are replayed in order. unified-planning's
SequentialSimulator, reading the domain's own PDDL, checks that each recorded action is
applicable where it was taken and applies it; an action's cost is unified-planning's reading of
the domain's metric. Whether a task's goal holds is the toolkit's compiled goal (tasks.pddl) on the
state unified-planning reached: unified-planning evaluates a quantified goal such as the
blockworld's by expanding it, seconds a state. Checked, per task:
- a task recorded as already satisfied holds when it is drawn;
- the executed plan has the row's length and cost, its goal holds after its last action exactly
  when the row says success, and after no earlier one (the world stops at completion);
- a failed task completed by the fallback: the completion reaches the goal at the row's
  completion cost, and the row charges executed + completion;
- our simulator reaches the same state as unified-planning after every task;
and per sequence, the recorded reset seed and total cost. What stays the toolkit's own is the reset
sampling, the goals and a completed task's consumption (tasks.pddl), applied to the state
unified-planning reached. A file made with other domain content, or one that records no plans (written before
results kept them), is named, not replayed. Exit status 1 if any file disagrees.
"""

from __future__ import annotations

import sys
from pathlib import Path

from planning import cli
from planning.errors import DomainError


class Validator:
    """unified-planning's simulator over one layout: plans replayed, their costs read off the domain's metric."""

    def __init__(self, model):
        from unified_planning.model.walkers import StateEvaluator
        from unified_planning.shortcuts import SequentialSimulator

        from planning.external.up_bridge import UPStates, up_names, up_problem

        self.model, self.names = model, up_names(model)
        self.problem = up_problem(model)
        self.sim = SequentialSimulator(problem=self.problem)
        self.conv = UPStates(model, self.problem, self.sim)
        self.evaluate = StateEvaluator(self.problem).evaluate
        metrics = [m for m in self.problem.quality_metrics if hasattr(m, "get_action_cost")]
        self.metric = metrics[0] if metrics else None

    def step(self, up_state, name: str):
        """(the state after the named ground action, its cost), both unified-planning's; a DomainError where the
        action is unknown or not applicable."""
        a = self.model.action_index.get(name)
        if a is None:
            raise DomainError(name, f"not a ground action of layout {self.model.layout}")
        action = self.problem.action(self.model.action_schema[a])
        params = [self.problem.object(self.names.object(o)) for o in self.model.action_args[a]]
        if not self.sim.is_applicable(up_state, action, params):
            raise DomainError(name, "not applicable under unified-planning")
        cost = 1
        if self.metric is not None:
            em, sub = self.problem.environment.expression_manager, self.problem.environment.substituter
            exp = sub.substitute(
                self.metric.get_action_cost(action), dict(zip(action.parameters, map(em.ObjectExp, params)))
            )
            cost = self.evaluate(exp, up_state).constant_value()
        return self.sim.apply(up_state, action, params), cost

    def run(self, task, state: int, plan: list[str], stop_at_goal: bool) -> tuple[int, int, int | None]:
        """Replay `plan` from our state: (the state reached, read back; its cost; the number of actions after
        which the goal first held, or None). `stop_at_goal`: check after every action (an executed plan stops
        at completion), else only at the end (a completion)."""
        up_state, cost, reached = self.conv.to_up(state), 0, None
        for k, name in enumerate(plan, 1):
            up_state, c = self.step(up_state, name)
            cost += c
            if reached is None and (stop_at_goal or k == len(plan)) and task.satisfied(self.conv.from_up(up_state)):
                reached = k
        return self.conv.from_up(up_state), int(cost), reached


def check_sequence(v: Validator, seq, rows: list[dict], recorded: dict) -> str | None:
    """The first disagreement of one sequence's rows with their replay, or None."""
    model = v.model
    if recorded.get("reset_seed") not in (None, seq.reset_seed):
        return f"reset seed {recorded['reset_seed']}, the sequence's is {seq.reset_seed}"
    state, total = model.reset_state(seq.reset_seed), 0
    for row, task in zip(rows, seq.tasks):
        where = f"sequence {seq.id} task {row['index']} {row['task']}"
        if row["task"] != task.name:
            return f"{where}: the sequence's task there is {task.name}"
        if row.get("auto"):
            if not task.satisfied(state):
                return f"{where}: recorded as already satisfied, but its goal does not hold when drawn"
            state = task.consume(state)
            continue
        plan = row.get("plan")
        if not isinstance(plan, list):
            return f"{where}: no plan recorded"
        start = state
        try:
            state, cost, reached = v.run(task, state, plan, stop_at_goal=True)
        except DomainError as e:
            return f"{where}: {e}"
        try:
            ours = start
            for name in plan:
                ours = model.apply(ours, model.action_index[name])
        except DomainError as e:
            return f"{where}: our simulator: {e}"
        if state != ours:
            return f"{where}: our simulator and unified-planning reach different states"
        executed = row.get("executed_cost", row["cost"])
        if (len(plan), cost) != (row["actions"], executed):
            return f"{where}: the plan costs {cost} in {len(plan)} actions, the row says {executed} in {row['actions']}"
        if row["success"] != (reached == len(plan)) or (reached is not None and reached < len(plan)):
            held = "never" if reached is None else f"after {reached} of {len(plan)} actions"
            return f"{where}: the row says success {row['success']}, the goal holds {held}"
        if row["success"]:
            state = task.consume(state)
        elif row.get("completed_by") == "fallback":
            completion = row.get("completion_plan")
            if not isinstance(completion, list):
                return f"{where}: a failed task completed by the fallback records no completion plan"
            try:
                state, rest, reached = v.run(task, state, completion, stop_at_goal=False)
            except DomainError as e:
                return f"{where}: its completion: {e}"
            if reached != len(completion) or rest != row.get("completion_cost"):
                return f"{where}: the completion costs {rest} and reaches the goal {reached is not None}"
            if row["cost"] != executed + rest:
                return f"{where}: charged {row['cost']}, executed {executed} + completion {rest}"
            state = task.consume(state)
        total += row["cost"]
    if recorded.get("cost") not in (None, total):
        return f"sequence {seq.id}: the rows cost {total}, the sequence records {recorded['cost']}"
    return None


def validate(path, domain: str | None = None, validators: dict | None = None) -> tuple[str, int, str]:
    """('ok' | 'skipped' | 'disagrees', the tasks replayed, a line saying why); see the module's docstring.
    `validators`: the Validator of each (domain folder, layout) met so far, reused across files."""
    from planning.atomic import read_json
    from planning.domain.compiler import compile_domain
    from planning.domain.identity import mismatch
    from planning.world.sequences import load

    data = read_json(path)
    if not isinstance(data, dict) or not isinstance(data.get("per_sequence"), list) or "per_task" not in data:
        return "skipped", 0, "not a results file of played sequences"
    validators = {} if validators is None else validators
    v = None
    for folder in dict.fromkeys([f"domains/{data.get('domain', 'restaurant')}", domain or cli.DEFAULT_DOMAIN]):
        key = (folder, data["layout"])
        if key not in validators and Path(folder).is_dir():
            try:
                validators[key] = Validator(compile_domain(folder, data["layout"]))
            except DomainError:  # not this folder's layout
                validators[key] = None
        if validators.get(key) and validators[key].model.name == data.get("domain", validators[key].model.name):
            v = validators[key]
            break
    if v is None:
        return "skipped", 0, f"no domain folder of {data.get('domain')!r} (name it with --domain)"
    other = mismatch(data, v.model)
    if other:
        return "skipped", 0, f"made with {other}"
    rows = [r for r in data["per_task"] if not r.get("auto")]
    if any("plan" not in r for r in rows):
        return "skipped", 0, "records no plans (written before results kept them): rerun its command with --force"
    stream = (data.get("config") or {}).get("stream")
    by_seq: dict = {}
    for r in data["per_task"]:
        by_seq.setdefault(r["sequence"], []).append(r)
    recorded = {s["id"]: s for s in data.get("per_sequence", [])}
    tasks = 0
    for seq in load(v.model, sorted(by_seq), stream):
        rows = sorted(by_seq[seq.id], key=lambda r: r["index"])
        problem = check_sequence(v, seq, rows, recorded.get(seq.id, {}))
        if problem:
            return "disagrees", tasks, problem
        tasks += len(rows)
    return "ok", tasks, f"{tasks} tasks of {len(by_seq)} sequences replayed: actions, costs and goals agree"


def main() -> None:
    p = cli.parser(
        __doc__.splitlines()[0],
        layout=False,
        out=None,
        helps={"domain": "domain folder of files whose domain is not domains/<its name> (default: %(default)s)"},
    )
    p.add_argument("files", nargs="*", help="results files")
    p.add_argument("--all", action="store_true", help="every results file under results/")

    def run():
        args = p.parse_args()
        files = [Path(f) for f in args.files]
        if args.all:
            files += sorted(f for f in Path("results").glob("*.json") if not f.name.endswith(".partial.json"))
        if not files:
            raise DomainError("validate", "name results files, or --all")
        validators, bad = {}, 0
        for f in files:
            verdict, _, why = validate(f, args.domain, validators)
            if verdict == "skipped" and args.all and why.startswith("not a results file"):
                continue
            bad += verdict == "disagrees"
            print(f"{f}: {verdict}: {why}")
        if bad:
            sys.exit(1)

    cli.run(run)


if __name__ == "__main__":
    main()

"""Check a domain folder before any tool runs on it: every layout parsed, grounded and compiled.

    python -m planning.world.domain_check DIR [--layout NAME] [--no-costs] [--time-limit SECONDS]

What it checks, beyond what compiling a layout refuses (a malformed file, an
unknown object, a task type without a schema, probabilities that do not sum to
1, a reset atom no action changes):

- domain.toml's tables: each known table's keys and values ([stream], [reward],
  [search], [coordinates], [training]'s per-layout tables), unknown tables and
  keys (a warning: no tool reads them);
- the task distribution of each layout: the instances' probabilities sum to 1,
  [stream] first_task names an instance, every task can be completed from the
  start state (the problem's :init; an optimal plan by planning.search.optimal,
  LM-cut, so it needs no rooms), a type of probability 0 that no stream draws;
- task streams ([streams.<name>], `planning.world.streams`): a known kind, types that [tasks]
  draws, every transition row and phase mix summing to 1, phases in order;
- [preparation] (`planning.world.preparation`): its actions are the domain's, its types the layout's;
- resets: every world a reset can draw (each combination of the [[reset]] choices);
- rooms: every listed object exists, and every location (an object of the
  family the listed ones belong to) is in exactly one room, else a warning: the
  pattern databases treat an unlisted location as an object to track (the GNN
  dataset's labelling goes from about 1.5 s to 46 s on a small office domain),
  and without rooms they are not used at all;
- [heads]: the factored actions build, and no two applicable actions share a
  label in the start state, the reset worlds and short random walks from them;
- defaults that change a result silently: no [search] beta (β = 1.0: the guided
  agents play exactly the myopic plan), no [reward] cost_scale (1 PDDL unit per
  reward unit).

It prints a short summary per layout (atoms, ground actions, task instances, the
myopic cost of each task type from the start state) on stdout, and one line per
problem on stderr, `error: FILE:LINE: what` or `warning: FILE:LINE: what` (the
line where it is known). Exit status 0 when there is no error (warnings alone
are fine), 2 on any error.
"""

from __future__ import annotations

import re
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from planning import cli
from planning.errors import DomainError

KNOWN_TABLES = (
    "layouts",
    "tasks",
    "reset",
    "coordinates",
    "heads",
    "stream",
    "streams",
    "reward",
    "training",
    "search",
    "gnn",
    "preparation",
    "published",
)
"""The top-level tables of domain.toml that some tool reads."""
LAYOUT_KEYS = ("problem", "rooms", "tasks", "reset", "coordinates")
STREAM_KEYS = {
    "tasks_per_reset": "a positive integer",
    "max_actions": "a positive integer",
    "first_task": 'a task instance such as "clear(c)"',
    "terminal_reset": "true or false",
}
REWARD_KEYS = {"cost_scale": "a positive number", "goal_reward": "a number", "gamma": "a number in (0, 1]"}
SEARCH_KEYS = {"beta": "a number of at least 1", "budget": "a non-negative integer", "depth_cap": "a positive integer"}
SEARCH_DEFAULTS = {"beta": 1.0, "budget": 5000, "depth_cap": 20}
"""learning.agents.guided's defaults where [search] does not give a value."""
HORIZONS = ("myopic", "anticipatory")
MAX_WORLDS = 256  # reset worlds checked (the combinations of [[reset]] choices)


@dataclass(frozen=True)
class Problem:
    """One finding: an error (the folder cannot be used as it is) or a warning."""

    level: str
    file: str
    line: int | None
    message: str

    def __str__(self) -> str:
        where = f"{self.file}:{self.line}" if self.line else self.file
        return f"{self.level}: {where}: {self.message}"


@dataclass
class LayoutSummary:
    domain: str  # the PDDL define
    layout: str
    atoms: int
    actions: int
    tasks: int
    types: int
    resets: int
    worlds: int
    rooms: int
    locations: int
    costs: dict = field(default_factory=dict)  # task type -> [(instance name, probability, cost or None)]


# ---- lines in domain.toml and the PDDL files ------------------------------------------------
def toml_index(text: str) -> dict:
    """{key path: line}: every table header ([a.b], [[a]] as (a, k)) and every key under it (first line)."""
    index: dict = {}
    current: tuple = ()
    arrays: dict = {}
    for n, raw in enumerate(text.splitlines(), start=1):
        line = raw.split("#", 1)[0].strip() if not raw.lstrip().startswith("#") else ""
        if not line:
            continue
        m = re.match(r"^\[\[\s*([^\]]+?)\s*\]\]", line)
        if m:
            name = tuple(_unquote(p) for p in m.group(1).split("."))
            k = arrays.get(name, 0)
            arrays[name] = k + 1
            current = (*name, k)
            index.setdefault(current, n)
            continue
        m = re.match(r"^\[\s*([^\]]+?)\s*\]", line)
        if m:
            current = tuple(_unquote(p) for p in m.group(1).split("."))
            index.setdefault(current, n)
            continue
        m = re.match(r'^("[^"]*"|[A-Za-z0-9_.-]+)\s*=', line)
        if m:
            index.setdefault((*current, *(_unquote(p) for p in m.group(1).split("."))), n)
    return index


def _unquote(part: str) -> str:
    return part.strip().strip('"').strip("'")


class Lines:
    """Where a finding sits: line numbers in domain.toml by key path, in a PDDL file by what it names."""

    def __init__(self, folder: Path):
        self.folder = folder
        self.config = folder / "domain.toml"
        try:
            self.index = toml_index(self.config.read_text())
        except (OSError, UnicodeDecodeError):
            self.index = {}

    def toml(self, *path) -> int | None:
        """The line of a key path, or of the nearest enclosing table or key that has one."""
        path = tuple(path)
        while path:
            if path in self.index:
                return self.index[path]
            below = [n for k, n in self.index.items() if k[: len(path)] == path]
            if below:
                return min(below)
            path = path[:-1]
        return None

    def of_error(self, e: DomainError) -> tuple[str, int | None]:
        """(file, line) of a front-end error, from what its message names."""
        where, reason = e.where, e.reason
        m = re.match(r"^(.*\.(?:pddl|toml)):(\d+)$", where)
        if m:  # the front end named the line itself
            return m.group(1), int(m.group(2))
        path = Path(where)
        if path.suffix == ".toml":
            return where, self._toml_line(reason)
        if path.suffix == ".pddl":
            return where, pddl_line(path, reason)
        return where, None

    def _toml_line(self, reason: str) -> int | None:
        m = re.search(r"\[\[reset\]\] entry (\d+)", reason)
        if m:
            return self.toml("reset", int(m.group(1)) - 1)
        m = re.search(r"\[heads\] (?:names unknown action '([^']+)'|([\w-]+):)", reason)
        if m:
            return self.toml("heads", m.group(1) or m.group(2))
        m = re.search(r"unknown layout '([^']+)'", reason)
        if m:
            return self.toml("layouts")
        m = re.search(r"\btask(?: type)? '?([\w-]+)'?", reason)
        if m and ("tasks", m.group(1)) in {k[:2] for k in self.index}:
            key = re.search(r"'(\?[\w-]+)'|(\?[\w-]+)", reason)
            return self.toml("tasks", m.group(1), "arguments") if key else self.toml("tasks", m.group(1))
        if "probabilities sum" in reason:
            return self.toml("tasks")
        m = re.search(r"'([^']+)'", reason)
        if m:
            return _first_line(self.config, m.group(1))
        return None


def _first_line(path: Path, needle: str) -> int | None:
    try:
        for n, line in enumerate(path.read_text().splitlines(), start=1):
            if needle in line.split(";", 1)[0].split("#", 1)[0]:
                return n
    except (OSError, UnicodeDecodeError):
        pass
    return None


def pddl_line(path: Path, reason: str) -> int | None:
    """The line a PDDL error is about: the parser's own "line N", else the action or the name it quotes."""
    m = re.search(r"\bline (\d+)", reason)
    if m:
        return int(m.group(1))
    m = re.search(r"\b(?:task|action)(?: type)? '?([\w-]+)'?", reason)
    if m:
        line = _pddl_token_line(path, rf"\(:action\s+{re.escape(m.group(1))}\b")
        if line:
            return line
    m = re.search(r"[\"']([^\"']+)[\"']", reason)
    if m:
        return _pddl_token_line(path, rf"[(\s]{re.escape(m.group(1))}[)\s]")
    return None


def _pddl_token_line(path: Path, pattern: str) -> int | None:
    try:
        lines = path.read_text().splitlines()
    except (OSError, UnicodeDecodeError):
        return None
    rx = re.compile(pattern, re.IGNORECASE)
    for n, line in enumerate(lines, start=1):
        if rx.search(" " + line.split(";", 1)[0] + " "):
            return n
    return None


# ---- the checker ----------------------------------------------------------------------------
class Checker:
    """Runs every check on a folder; `problems` and `summaries` hold what it found."""

    def __init__(self, folder, layouts=None, costs: bool = True, time_limit: float = 20.0):
        self.folder = Path(folder)
        self.only = layouts
        self.costs, self.time_limit = costs, time_limit
        self.problems: list[Problem] = []
        self.summaries: list[LayoutSummary] = []
        self.lines = Lines(self.folder)
        self.config: dict = {}

    @property
    def errors(self) -> list[Problem]:
        return [p for p in self.problems if p.level == "error"]

    @property
    def warnings(self) -> list[Problem]:
        return [p for p in self.problems if p.level == "warning"]

    def _add(self, level: str, file, line, message: str) -> None:
        p = Problem(level, str(file), line, message)
        if p not in self.problems:
            self.problems.append(p)

    def error(self, message: str, *path, file=None, line=None) -> None:
        self._add("error", file or self.lines.config, line if line is not None else self._line(path), message)

    def warn(self, message: str, *path, file=None, line=None) -> None:
        self._add("warning", file or self.lines.config, line if line is not None else self._line(path), message)

    def _line(self, path) -> int | None:
        return self.lines.toml(*path) if path else None

    def front_end(self, e: DomainError) -> None:
        file, line = self.lines.of_error(e)
        self._add("error", file, line, e.reason)

    # ---- the whole folder ----
    def run(self) -> "Checker":
        from planning.domain.folder import read_config

        try:
            self.config = read_config(self.folder)
        except DomainError as e:
            self.front_end(e)
            return self
        layouts = self.config.get("layouts", {})
        if not isinstance(layouts, dict) or not layouts:
            self.error("declares no [layouts.<name>] table: a layout names its problem file and rooms", "layouts")
            return self
        if self.only is not None:
            unknown = [x for x in self.only if x not in layouts]
            if unknown:
                raise DomainError(self.lines.config, f"unknown layout '{unknown[0]}' (known: {', '.join(layouts)})")
        names = list(layouts) if self.only is None else list(self.only)
        self.check_tables(list(layouts))
        models = [self.check_layout(layout) for layout in names]
        if self.only is None and None not in models:
            self._check_coordinate_objects(models)
        return self

    def check_tables(self, layouts: list[str]) -> None:
        cfg = self.config
        for key in cfg:
            if key not in KNOWN_TABLES:
                self.warn(f"unknown table [{key}]: no tool reads it (known: {', '.join(KNOWN_TABLES)})", key)
        for name, entry in cfg.get("layouts", {}).items():
            if not isinstance(entry, dict):
                self.error(f"[layouts.{name}] is {entry!r}, not a table", "layouts", name)
                continue
            for key in entry:
                if key not in LAYOUT_KEYS:
                    self.warn(
                        f"[layouts.{name}] has unknown key '{key}' (known: {', '.join(LAYOUT_KEYS)})",
                        "layouts",
                        name,
                        key,
                    )
        self._check_tasks()
        self._check_keys("stream", STREAM_KEYS)
        stream = cfg.get("stream", {})
        if isinstance(stream, dict):
            for key in ("tasks_per_reset", "max_actions"):
                if key in stream and not _positive_int(stream[key]):
                    self.error(f"[stream] {key} is {stream[key]!r}, not {STREAM_KEYS[key]}", "stream", key)
            if "terminal_reset" in stream and not isinstance(stream["terminal_reset"], bool):
                self.error(
                    f"[stream] terminal_reset is {stream['terminal_reset']!r}, not true or false",
                    "stream",
                    "terminal_reset",
                )
            if "first_task" in stream and not isinstance(stream["first_task"], str):
                self.error(
                    f"[stream] first_task is {stream['first_task']!r}, not {STREAM_KEYS['first_task']}",
                    "stream",
                    "first_task",
                )
        self._check_reward()
        self._check_search(layouts)
        self._check_training(layouts)
        self._check_coordinates()

    def _check_tasks(self) -> None:
        from planning.domain.tasks import check_entry

        table = self.config.get("tasks", {})
        if not isinstance(table, dict):
            self.error(f"tasks is {table!r}, not a table of [tasks.<type>] tables", "tasks")
            return
        if not table:
            self.error("no [tasks.<type>] table: the task distribution is empty", "tasks")
            return
        ok = True
        for ttype, entry in table.items():
            try:
                check_entry(ttype, entry, self.lines.config)
            except DomainError as e:
                self.error(e.reason, "tasks", ttype)
                ok = False
        layouts = self.config.get("layouts", {})
        shared = any(not (isinstance(e, dict) and "tasks" in e) for e in layouts.values())
        if ok and shared:  # some layout reads [tasks] as it is (the others: their overrides, compiled)
            total = sum(float(t["probability"]) for t in table.values())
            if abs(total - 1.0) > 1e-9:
                self.error(f"task type probabilities sum to {total:g}, not 1", "tasks")

    def _check_keys(self, name: str, known: dict) -> None:
        table = self.config.get(name)
        if table is None:
            return
        if not isinstance(table, dict):
            self.error(f"[{name}] is {table!r}, not a table", name)
            return
        for key in table:
            if key not in known:
                self.warn(f"[{name}] has unknown key '{key}' (known: {', '.join(known)})", name, key)

    def _check_reward(self) -> None:
        self._check_keys("reward", REWARD_KEYS)
        reward = self.config.get("reward", {})
        if not isinstance(reward, dict):
            return
        if "cost_scale" not in reward:
            self.warn(
                "no [reward] cost_scale: the learners take 1 PDDL cost unit per reward unit (the restaurant "
                "uses 100); set it to the cost of a typical action over the reward you mean it to have",
                "reward",
            )
        elif not _number(reward["cost_scale"]) or reward["cost_scale"] <= 0:
            self.error(
                f"[reward] cost_scale is {reward['cost_scale']!r}, not {REWARD_KEYS['cost_scale']}",
                "reward",
                "cost_scale",
            )
        if "goal_reward" in reward and not _number(reward["goal_reward"]):
            self.error(f"[reward] goal_reward is {reward['goal_reward']!r}, not a number", "reward", "goal_reward")
        if "gamma" in reward and (not _number(reward["gamma"]) or not 0 < reward["gamma"] <= 1):
            self.error(f"[reward] gamma is {reward['gamma']!r}, not {REWARD_KEYS['gamma']}", "reward", "gamma")

    def _check_search(self, layouts: list[str]) -> None:
        self._check_keys("search", SEARCH_KEYS)
        search = self.config.get("search")
        if search is None:
            self.warn(
                "no [search]: rl-guided takes beta = 1.0 (it then plays exactly the myopic plan), budget "
                "5000 and depth_cap 20; set [search] beta (> 1 lets it leave the myopic plan)",
                "search",
            )
            return
        if not isinstance(search, dict):
            return
        if "beta" not in search:
            self.warn("[search] has no beta: rl-guided takes 1.0 and plays exactly the myopic plan", "search")
        for key, what in SEARCH_KEYS.items():
            if key not in search:
                continue
            value = search[key]
            per = value if isinstance(value, dict) else {layout: value for layout in layouts}
            if isinstance(value, dict):
                for layout in layouts:
                    if layout not in value:
                        self.error(f"[search] {key} has no entry for layout '{layout}'", "search", key)
                for other in value:
                    if other not in layouts:
                        self.warn(f"[search] {key} names '{other}', which is not a layout", "search", key)
            for layout, v in per.items():
                if not _search_value(key, v):
                    label = f"[search] {key}" + (f" for {layout}" if isinstance(value, dict) else "")
                    self.error(f"{label} is {v!r}, not {what}", "search", key)
                    break

    def _check_training(self, layouts: list[str]) -> None:
        table = self.config.get("training")
        if table is None:
            return
        if not isinstance(table, dict):
            self.error(f"[training] is {table!r}, not a table", "training")
            return
        for key, value in table.items():
            if not isinstance(value, dict):
                continue
            for sel, inner in value.items():
                if sel not in layouts and sel not in HORIZONS:
                    self.warn(
                        f"[training] {key} is keyed by '{sel}', neither a layout ({', '.join(layouts)}) "
                        f"nor a horizon ({', '.join(HORIZONS)})",
                        "training",
                        key,
                    )
                elif sel in layouts and isinstance(inner, dict):
                    bad = [h for h in inner if h not in HORIZONS]
                    if bad:
                        self.warn(f"[training] {key}.{sel} is keyed by '{bad[0]}', not a horizon", "training", key)

    def _check_coordinates(self) -> None:
        tables = [(("coordinates",), "[coordinates]", self.config.get("coordinates"))]
        for layout, entry in self.config.get("layouts", {}).items():
            if isinstance(entry, dict) and "coordinates" in entry:
                tables.append(
                    (("layouts", layout, "coordinates"), f"[layouts.{layout}.coordinates]", entry["coordinates"])
                )
        for path, label, coords in tables:
            if coords is None:
                continue
            if not isinstance(coords, dict):
                self.error(f"{label} is {coords!r}, not a table of object = [x, y]", *path)
                continue
            for name, xy in coords.items():
                if not (isinstance(xy, list) and len(xy) == 2 and all(_number(v) for v in xy)):
                    self.error(f"{label} {name} is {xy!r}, not [x, y]", *path, name)

    # ---- one layout ----
    def check_layout(self, layout: str):
        """Compile one layout and check it; its model, or None where it does not compile."""
        from planning.domain.compiler import compile_source
        from planning.domain.folder import read_domain

        try:
            model = compile_source(read_domain(self.folder, layout))
        except DomainError as e:
            self.front_end(e)
            return None
        except Exception as e:  # a parser or grounder crash is still one line about this layout
            self.error(
                f"layout {layout}: cannot compile ({type(e).__name__}: {' '.join(str(e).split())})", "layouts", layout
            )
            return None
        total = float(sum(t.probability for t in model.tasks))
        if abs(total - 1.0) > 1e-9:
            self.error(f"layout {layout}: the task instances' probabilities sum to {total:g}, not 1", "tasks")
        first = self._first_task(model)
        if first is not False:
            self._check_unused_types(model, first)
        self._check_streams(model)
        self._check_preparation(model)
        rooms, locations = self._check_rooms(model)
        worlds = reset_worlds(model)
        self._check_heads(model, worlds)
        summary = LayoutSummary(
            model.name,
            layout,
            model.n_atoms,
            model.n_actions,
            len(model.tasks),
            len({t.type for t in model.tasks}),
            len(model.resets),
            len(worlds),
            rooms,
            locations,
        )
        if self.costs:
            summary.costs = self._myopic_costs(model)
        self.summaries.append(summary)
        return model

    def _first_task(self, model):
        """[stream] first_task's instance; None where there is none, False where it names no instance."""
        first = self.config.get("stream", {}).get("first_task") if isinstance(self.config.get("stream"), dict) else None
        if not isinstance(first, str):
            return None if first is None else False
        try:
            return model.tasks.get(first)
        except DomainError:
            names = ", ".join(t.name for t in list(model.tasks)[:4])
            self.error(
                f"[stream] first_task '{first}' is not a task instance of layout {model.layout} "
                f"(instances: {names}{', ...' if len(model.tasks) > 4 else ''})",
                "stream",
                "first_task",
            )
            return False

    def _check_streams(self, model) -> None:
        """[streams.<name>]: each declared task stream reads (`planning.world.streams`)."""
        from planning.world.streams import streams

        try:
            streams(model)
        except DomainError as e:
            self.error(f"layout {model.layout}: {e.reason}", "streams")

    def _check_preparation(self, model) -> None:
        """[preparation]: its actions are the domain's, its types the layout's (`planning.world.preparation`)."""
        from planning.world.preparation import Preparation

        try:
            Preparation.of(model)
        except DomainError as e:
            self.error(f"layout {model.layout}: {e.reason}", "preparation")

    def _check_unused_types(self, model, first) -> None:
        by_type: dict[str, float] = {}
        for t in model.tasks:
            by_type[t.type] = by_type.get(t.type, 0.0) + t.probability
        for ttype, p in by_type.items():
            if p == 0 and (first is None or first.type != ttype):
                self.warn(
                    f"task type {ttype} has probability 0 and is not [stream] first_task: no stream draws it",
                    "tasks",
                    ttype,
                )

    def _check_coordinate_objects(self, models: list) -> None:
        """A warning for a [coordinates] entry that names an object of no layout (a typo)."""
        coords = self.config.get("coordinates", {})
        if not isinstance(coords, dict) or not models:
            return
        known = {o for m in models for o in m.objects}
        for name in coords:
            if name not in known:
                self.warn(f"[coordinates] {name}: no such object in any layout", "coordinates", name)
        for m in models:
            own = self.config["layouts"][m.layout].get("coordinates")
            for name in own if isinstance(own, dict) else ():
                if name not in m.objects:
                    self.warn(
                        f"[layouts.{m.layout}.coordinates] {name}: no such object in layout {m.layout}",
                        "layouts",
                        m.layout,
                        "coordinates",
                        name,
                    )

    def _check_rooms(self, model) -> tuple[int, int]:
        layout = model.layout
        rooms = model.config.get("layouts", {}).get(layout, {}).get("rooms")
        path = ("layouts", layout, "rooms")
        if rooms is None:
            self.warn(
                f"layout {layout} has no rooms: the searches cannot use pattern databases (they take LM-cut, "
                "slower on large layouts) and the GNN graph has no rooms",
                *path,
            )
            return 0, 0
        if not isinstance(rooms, dict) or not all(
            isinstance(v, list) and all(isinstance(o, str) for o in v) for v in rooms.values()
        ):
            self.error(f"rooms of layout {layout} must be a table room = [locations], not {rooms!r}", *path)
            return 0, 0
        known = set(model.objects)
        seen: dict[str, str] = {}
        for room, objs in rooms.items():
            for o in objs:
                if o not in known:
                    self.error(
                        f"room {room} of layout {layout} lists '{o}', which is not an object of its problem", *path
                    )
                elif o in seen and seen[o] != room:
                    self.warn(
                        f"'{o}' is in two rooms of layout {layout} ({seen[o]} and {room}): a location "
                        "belongs to one room",
                        *path,
                    )
                seen.setdefault(o, room)
        listed = [o for o in seen if o in known]
        families = {_family(model, o) for o in listed}
        candidates = [o for f in sorted(families) for o in model.objects_of(f)]
        missing = [o for o in dict.fromkeys(candidates) if o not in seen]
        if missing:
            shown = ", ".join(missing[:5]) + (", ..." if len(missing) > 5 else "")
            self.warn(
                f"{len(missing)} location{'s' if len(missing) > 1 else ''} of layout {layout} in no room "
                f"({shown}): the pattern databases track them as objects, many times slower (the labelling "
                "oracle, the GNN dataset); list every location in one room",
                *path,
            )
        return len(rooms), len(listed)

    def _check_heads(self, model, worlds: list[int]) -> None:
        from planning.domain.factored import factored_actions

        try:
            fa = factored_actions(model)
        except DomainError as e:
            self.front_end(e)
            return
        states = [model.init, *worlds]
        try:
            states += model.random_walk_states(64, seed=0, walk=16)
        except Exception:  # a world with no applicable action: the walk cannot go on; the label check still runs
            pass
        for s in dict.fromkeys(states):
            try:
                fa.applicable_labels(model, s)
            except DomainError as e:
                schema = e.where.split("(", 1)[0]
                self.error(f"[heads] {schema}: {e.where} {e.reason}", "heads", schema)
                return

    def _myopic_costs(self, model) -> dict:
        from planning.domain.batched import BatchedModel
        from planning.search.optimal import optimal_plans

        tasks = list(model.tasks)
        results = optimal_plans(BatchedModel(model), model.init, tasks, time_limit=self.time_limit, heuristic="lmcut")
        out: dict = {}
        for t, r in zip(tasks, results):
            out.setdefault(t.type, []).append((t.name, t.probability, r.cost))
            if r.cost is None and r.complete:
                self.error(
                    f"task {t.name} cannot be completed from the start state of layout {model.layout} (no plan exists)",
                    file=model.files["tasks"],
                    line=pddl_line(Path(model.files["tasks"]), f"task {t.type}"),
                )
            elif r.cost is None:
                self.warn(
                    f"task {t.name}: no plan found from the start state of layout {model.layout} within "
                    f"{self.time_limit:g} s (--time-limit)",
                    file=model.files["tasks"],
                    line=pddl_line(Path(model.files["tasks"]), f"task {t.type}"),
                )
        return out


def reset_worlds(model, limit: int = MAX_WORLDS) -> list[int]:
    """The worlds a reset can draw (each combination of the [[reset]] choices of probability > 0), at most `limit`."""
    return model.reset_worlds(limit)


def _family(model, obj: str) -> str:
    """The type just below `object` that an object belongs to (location, cell, thing, ...)."""
    lang = model.source.problem.language
    sort = lang.get(obj).sort
    parents = lang.immediate_parent
    while parents.get(sort) is not None and parents[sort].name != "object":
        sort = parents[sort]
    return sort.name


def _number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _positive_int(v) -> bool:
    return isinstance(v, int) and not isinstance(v, bool) and v >= 1


def _search_value(key: str, v) -> bool:
    if key == "beta":
        return _number(v) and v >= 1
    if key == "budget":
        return isinstance(v, int) and not isinstance(v, bool) and v >= 0
    return _positive_int(v)


# ---- the report -----------------------------------------------------------------------------
def cost_text(instances: list) -> str:
    """'1,475' for one instance; 'min–max, mean m over P (n instances)' for several; 'no plan' where none."""
    costs = [c for _, _, c in instances]
    if len(instances) == 1:
        return "no plan" if costs[0] is None else f"{costs[0]:,}"
    known = [(p, c) for _, p, c in instances if c is not None]
    if not known:
        return f"no plan ({len(instances)} instances)"
    cs = [c for _, c in known]
    ps = np.array([p for p, _ in known])
    mean = float(ps @ np.array(cs) / ps.sum()) if ps.sum() > 0 else float(np.mean(cs))
    unknown = len(instances) - len(known)
    tail = f", {unknown} without a plan" if unknown else ""
    if min(cs) == max(cs):
        return f"{cs[0]:,} ({len(instances)} instances{tail})"
    return f"{min(cs):,}–{max(cs):,}, mean {mean:,.0f} over P ({len(instances)} instances{tail})"


def summary_lines(s: LayoutSummary) -> list[str]:
    rooms = f"{s.rooms} room{'s' if s.rooms != 1 else ''} ({s.locations} locations)" if s.rooms else "no rooms"
    lines = [
        f"{s.domain} {s.layout}: {s.atoms} atoms, {s.actions} ground actions, {s.tasks} task instances of "
        f"{s.types} type{'s' if s.types != 1 else ''}, {s.resets} reset entr{'ies' if s.resets != 1 else 'y'} "
        f"({s.worlds} world{'s' if s.worlds != 1 else ''}), {rooms}"
    ]
    if s.costs:
        lines.append(
            "  myopic cost from the start state: " + "; ".join(f"{t} {cost_text(inst)}" for t, inst in s.costs.items())
        )
    return lines


def main() -> None:
    p = cli.parser(
        __doc__.splitlines()[0], out=None, helps={"layout": "check only this layout (default: every layout)"}
    )
    p.add_argument("folder", nargs="?", default=None, help="domain folder (default: --domain)")
    p.add_argument("--no-costs", action="store_true", help="skip the myopic costs from the start state")
    p.add_argument(
        "--time-limit",
        type=float,
        default=20.0,
        help="seconds for the myopic costs of one layout (default: %(default)s)",
    )
    args = p.parse_args()
    if not args.time_limit > 0:
        raise DomainError("--time-limit", f"must be positive, not {args.time_limit}")
    folder = Path(args.folder or args.domain)
    checker = Checker(folder, None if args.layout is None else [args.layout], not args.no_costs, args.time_limit).run()
    for s in checker.summaries:
        print("\n".join(summary_lines(s)))
    for prob in checker.problems:
        print(prob, file=sys.stderr)
    n_e, n_w = len(checker.errors), len(checker.warnings)
    verdict = "ok" if not n_e else "not usable as it is"
    print(f"{folder}: {verdict}: {n_e} error{'s' if n_e != 1 else ''}, {n_w} warning{'s' if n_w != 1 else ''}")
    if n_e:
        sys.exit(2)


if __name__ == "__main__":
    cli.run(main)

"""Reading the results behind a report row: which files exist, whether they are what the row expects, and
their figures over seeds.

A run's results file is *used* only when it is finished (no OUT.partial.json
beside it), was made by the agent and configuration the row's command line
builds (`planning.world.results.difference`: agent, layout, every config key,
the checkpoint's step and evaluation among them) and, where it records one, with
the checkpoint file that is there now (sha256). What would make a figure built on it
doubtful is a *flag* (the report marks the figure): a commit outside this
history, uncommitted code at the time, a sequence set other than the ten,
failed tasks counted at their executed cost only (written before failures were
charged). What a reader should know but does not change the figure is a
*note*: no provenance block (written before results files recorded one; the
report then names the commit that last touched the file).
"""

from __future__ import annotations

import math
import os
import subprocess
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

from experiments.registry import AGENTS, agent_class
from experiments.report.specs import Row, Run
from planning import atomic, cli
from planning.atomic import read_json
from planning.errors import DomainError
from planning.world.sequences import COUNT, DEVELOPMENT

ALL = tuple(range(COUNT))
HELD_OUT = tuple(i for i in ALL if i not in DEVELOPMENT)
SPLITS = {"all ten": ALL, "development (01, 03, 06)": tuple(DEVELOPMENT), "held-out seven": HELD_OUT}


# ---- git and files ----------------------------------------------------------------------------
def git(*args) -> str | None:
    """Output of a git command in this checkout (None if git or the checkout is missing)."""
    try:
        r = subprocess.run(
            ["git", *args], capture_output=True, text=True, timeout=20, cwd=Path(__file__).resolve().parents[1]
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return r.stdout.strip() if r.returncode == 0 else None


@lru_cache(maxsize=None)
def in_history(commit: str) -> bool:
    """True if `commit` is HEAD or one of its ancestors."""
    try:
        r = subprocess.run(
            ["git", "merge-base", "--is-ancestor", commit, "HEAD"],
            capture_output=True,
            timeout=20,
            cwd=Path(__file__).resolve().parents[1],
        )
    except (OSError, subprocess.SubprocessError):
        return False
    return r.returncode == 0


@lru_cache(maxsize=None)
def last_commit(path: str) -> str | None:
    """'<short hash> <date>' of the last commit that touched `path` (None if never committed)."""
    return git("log", "-1", "--format=%h %cs", "--", path) or None


@lru_cache(maxsize=None)
def sha256(path: str) -> str | None:
    """A checkpoint's digest, read once per report."""
    return atomic.sha256(path)


def writer_pid(run: Run) -> int | None:
    """The id of another process evaluating this run now (its command line names the agent, the
    layout and the run's options), or None."""
    want = ["experiments.evaluate", *run.argv]
    for proc in Path("/proc").glob("[0-9]*"):
        try:
            argv = (proc / "cmdline").read_bytes().decode(errors="replace").split("\0")
        except OSError:
            continue
        if int(proc.name) != os.getpid() and all(tok in argv for tok in want):
            return int(proc.name)
    return None


# ---- one run --------------------------------------------------------------------------------
@dataclass
class Loaded:
    """One run's results file as the report sees it."""

    run: Run
    status: str  # ok | not run | no checkpoint | agent not registered | in progress | not used
    data: dict | None = None
    note: str = ""  # why it is not used, or what is missing
    flags: list = field(default_factory=list)
    notes: list = field(default_factory=list)
    accounting: str = ""

    @property
    def used(self) -> bool:
        return self.status == "ok"


def accounting(data: dict) -> tuple[str, str | None]:
    """(which cost a failed task carries in the file, a flag or None)."""
    failed = [r for r in data.get("per_task", []) if not r.get("success", True)]
    if not failed:
        return "no failed tasks", None
    if all(r.get("completed_by") == "fallback" for r in failed):
        return f"fallback ({len(failed)} failed tasks: executed + the optimal completion, which was executed)", None
    if all(r.get("completed_by") == "nothing" for r in failed):
        return f"abandoned, the thesis's protocol ({len(failed)} failed tasks at their executed cost)", None
    return (
        f"charged, world left unfinished ({len(failed)} failed tasks)",
        f"{len(failed)} failed tasks charged without executing their completion: written before the "
        "fallback was executed, so later tasks start from worlds no finished task leaves; rerun it with --force",
    )


def run_protocol(run: Run) -> str:
    """The failure protocol a row's run plays under (its --failure-protocol, else the default)."""
    from planning.world.results import DEFAULT_PROTOCOL

    opts = list(run.options)
    return opts[opts.index("--failure-protocol") + 1] if "--failure-protocol" in opts else DEFAULT_PROTOCOL


class Context:
    """What reading the runs needs once: the compiled layouts and the agents built from the rows' commands."""

    def __init__(self, domain: str = cli.DEFAULT_DOMAIN):
        self.domain = domain
        self._models: dict = {}
        self._trainings: list | None = None

    def model(self, layout: str):
        if layout not in self._models:
            from planning.domain.compiler import compile_domain

            self._models[layout] = compile_domain(self.domain, layout)
        return self._models[layout]

    def trainings(self) -> list[tuple[Path, dict]]:
        """Every Q-learning run's training file under results/ (`learning.export`), read once: (path, content)."""
        if self._trainings is None:
            found = ((p, read_finished(p)) for p in sorted(Path("results").glob("*training-*.json")))
            self._trainings = [(p, d) for p, d in found if d is not None and "horizon" in d]
        return self._trainings

    def training(self, checkpoint: str) -> dict | None:
        """The training file `learning.export` wrote with this checkpoint (one that names it), or None."""
        return next((d for _, d in reversed(self.trainings()) if d.get("checkpoint") == str(checkpoint)), None)

    def agent(self, run: Run):
        """The agent `experiments.evaluate` builds from the run's command line."""
        from oracles.command import run_options

        cls = agent_class(run.agent)
        p = cli.parser("reproduce", sequences=True, progress=True)
        p.add_argument("--agent")
        run_options(p)  # --failure-protocol and the other options every evaluation takes
        cls.options(p)
        args = p.parse_args(["--domain", self.domain, *run.argv])
        agent = cls.from_args(args, self.model(run.layout))
        if args.stream != "iid":  # as the evaluation does: the stream is in its config and its name
            agent.on_stream(args.stream)
        return agent


def load_run(run: Run, ctx: Context) -> Loaded:
    """Find, read and check one run's results file."""
    from planning.world.results import difference

    if run.agent not in AGENTS:
        return Loaded(run, "agent not registered", note=f"the agent `{run.agent}` is not registered yet")
    if run.checkpoint and not Path(run.checkpoint).is_file():
        return Loaded(run, "no checkpoint", note=f"`{run.checkpoint}` does not exist")
    out = Path(run.out)
    if Path(f"{out}.partial.json").is_file():
        pid = writer_pid(run)
        return Loaded(
            run,
            "in progress",
            note=f"being written by process {pid}"
            if pid
            else "interrupted: a .partial.json is there (reproduce resumes it)",
        )
    parts = sorted(Path(f"{out}.parts").glob("seq-*.json"))
    if parts and not out.is_file():
        pid = writer_pid(run)
        done = ", ".join(p.stem.removeprefix("seq-") for p in parts)
        return Loaded(
            run,
            "in progress",
            note=f"being written by process {pid}"
            if pid
            else f"interrupted: sequences {done} are in `{run.out}.parts/` (its command with --workers resumes them)",
        )
    if not out.is_file():
        return Loaded(run, "not run", note=f"`{run.out}` does not exist")
    data = read_json(out)
    if not isinstance(data, dict) or not isinstance(data.get("per_sequence"), list):
        return Loaded(run, "not used", note="not a results file (no per_sequence list)")
    try:
        agent = ctx.agent(run)
    except DomainError as e:
        return Loaded(run, "not used", data, note=f"the row's agent cannot be built: {e}")
    diff = difference(data, agent, ctx.model(run.layout), run_protocol(run))
    if diff:
        return Loaded(run, "not used", data, note=f"made with {diff} (the row expects the command's configuration)")
    loaded = Loaded(run, "ok", data)
    loaded.accounting, flag = accounting(data)
    if flag:
        loaded.flags.append(flag)
    seqs = sorted(s["id"] for s in data["per_sequence"])
    if seqs != list(ALL):
        loaded.flags.append(f"sequences {seqs} only")
    prov = data.get("provenance")
    if not isinstance(prov, dict):
        loaded.notes.append("no provenance block: written before results files recorded one")
    else:
        commit = prov.get("commit")
        if not commit:
            loaded.flags.append("provenance records no commit")
        elif not in_history(commit):
            loaded.flags.append(f"made at commit {commit[:10]}, which is not in this checkout's history")
        code = [f for f in prov.get("uncommitted_code") or [] if not f.startswith("tests/")]
        if code:
            loaded.flags.append(f"made with uncommitted changes to {', '.join(code[:4])}")
        if prov.get("checkpoint_sha256") and run.checkpoint and prov["checkpoint_sha256"] != sha256(run.checkpoint):
            loaded.status = "not used"
            loaded.note = f"made with another `{run.checkpoint}` (sha256 {prov['checkpoint_sha256'][:12]}…)"
    trained = ctx.training(run.checkpoint) if run.checkpoint else None
    if trained and isinstance(planned := (trained.get("config") or {}).get("steps"), int):
        if trained.get("steps", 0) < planned:
            loaded.flags.append(
                f"its checkpoint comes from an unfinished run ({trained['steps']:,} of {planned:,} steps trained)"
            )
    return loaded


# ---- one row over its seeds -----------------------------------------------------------------
def mean_std(xs: list[float]) -> tuple[float | None, float | None]:
    """Mean and sample standard deviation (None with fewer than two values)."""
    if not xs:
        return None, None
    m = sum(xs) / len(xs)
    return m, (math.sqrt(sum((x - m) ** 2 for x in xs) / (len(xs) - 1)) if len(xs) > 1 else None)


def split_figures(data: dict, ids) -> dict | None:
    """Cost, success and steps per task of one results file over the sequences `ids` it holds."""
    seqs = [s for s in data["per_sequence"] if s["id"] in set(ids)]
    tasks = sum(s["tasks"] for s in seqs)
    if not tasks:
        return None
    return {
        "cost": sum(s["cost"] for s in seqs) / tasks,
        "success": sum(s["successes"] for s in seqs) / tasks,
        "steps": sum(s["actions"] for s in seqs) / tasks,
        "sequences": [s["id"] for s in seqs],
        "tasks": tasks,
    }


@dataclass
class RowResult:
    """A row's runs as loaded, and its figures over the used ones."""

    row: Row
    loaded: list

    @property
    def used(self) -> list[dict]:
        return [x.data for x in self.loaded if x.used]

    @property
    def flagged(self) -> bool:
        return any(x.flags for x in self.loaded if x.used)

    def figures(self, ids=ALL) -> dict | None:
        """Mean and std over seeds of cost, success and steps per task on the sequences all used files hold."""
        used = self.used
        if not used:
            return None
        common = set(ids)
        for d in used:
            common &= {s["id"] for s in d["per_sequence"]}
        per = [split_figures(d, sorted(common)) for d in used]
        if not common or None in per:
            return None
        out = {"n": len(per), "sequences": sorted(common), "seeds": [x.run.seed for x in self.loaded if x.used]}
        for key in ("cost", "success", "steps"):
            out[key], out[f"{key}_std"] = mean_std([p[key] for p in per])
            out[f"{key}_seeds"] = [p[key] for p in per]
        return out


def load_rows(rows: list[Row], ctx: Context) -> dict[str, RowResult]:
    """{row key: RowResult} of one layout's rows."""
    return {row.key: RowResult(row, [load_run(run, ctx) for run in row.runs]) for row in rows}


def improvement(result: RowResult, reference: RowResult, ids=ALL) -> float | None:
    """(C_oracle − C) / C_oracle on the sequences both hold (None where either is missing)."""
    mine = result.figures(ids)
    if mine is None:
        return None
    ref = reference.figures(mine["sequences"])
    if ref is None or ref["sequences"] != mine["sequences"]:
        return None
    return (ref["cost"] - mine["cost"]) / ref["cost"]


def read_jsonl(path) -> list[dict]:
    """The rows of a run's metrics.jsonl, unreadable lines skipped; [] if the file is missing."""
    from learning.q.training import read_metrics

    return read_metrics(path, strict=False)[0] if Path(path).is_file() else []


def read_finished(path) -> dict | None:
    """A finished results file's content (None if missing or still being written); a corrupt one is a
    one-line error (`planning.atomic.read_json`), not a table row that reads as never run."""
    p = Path(path)
    if not p.is_file() or Path(f"{p}.partial.json").is_file():
        return None
    data = read_json(p)
    return data if isinstance(data, dict) else None


def curve(log: str) -> list[dict]:
    """A training run's logged rows: the curve its results file keeps (`learning.export`), or its metrics.jsonl."""
    if log.endswith(".json"):
        data = read_json(log, "training results file")
        if not isinstance(data, dict) or not isinstance(data.get("curve"), list):
            raise DomainError(log, "a training results file without its curve (learning.export writes it)")
        return data["curve"]
    return [r for r in read_jsonl(log) if "step" in r]

"""Evaluations spread over workers: each (agent configuration, canonical sequence) is one work item.

    python -m experiments.evaluate --agent myopic-oracle --planner internal --layout two-room --workers 2
    python -m experiments.evaluate --agent clairvoyant --K 3 --layout three-room --ray

A `Job` is one agent's evaluation (what `experiments.evaluate` runs). `play_over_workers`
finds the sequences a job still needs (a finished OUT of the same configuration and
OUT.partial.json count as done; a finished OUT made otherwise stops here unless `force`),
plays each on `planning.parallel`'s workers (local processes or Ray), and writes each
sequence's rows, as it finishes, to OUT.parts/seq-NN.json with their provenance (commit,
command, worker host and pid); a rerun reuses those. When a job's sequences are all in,
their rows go into OUT.partial.json and the parts are removed; `planning.world.runner.evaluate`
then writes OUT from it exactly as after a serial run (the per-task `seconds` and
`wall_seconds` are timings and differ).

That holds because every agent's results depend only on the sequence: `start(model,
sequence)` resets whatever an agent carries (the random policy reseeds from its seed and the
sequence id). A worker builds each agent once (`from_args` with the command's own agent options,
`experiments.registry.agent_options`) and keeps it for the next sequences it is handed.
"""

from __future__ import annotations

import json
import time
from dataclasses import asdict, dataclass
from pathlib import Path

from planning.atomic import write_json
from planning.domain.compiler import compile_domain
from planning.domain.identity import identity
from planning.errors import DomainError
from planning.parallel import provenance, run_items
from planning.world.results import DEFAULT_PROTOCOL, difference
from planning.world.runner import play_sequence
from planning.world.sequences import load

from .registry import agent_options, build


@dataclass
class Job:
    """One agent's evaluation on some canonical sequences, written to `out`."""

    agent_name: str  # the registry name
    options: object  # the agent's options it is built from (experiments.registry.agent_options)
    domain: str  # the domain folder the layout was compiled from
    model: object  # the compiled layout
    agent: object  # the agent, built here: its name and config name the results
    ids: list
    out: str
    force: bool = False
    protocol: str = DEFAULT_PROTOCOL  # the failure protocol the command plays under (--failure-protocol)
    log: str | None = None  # the agent's JSON-lines log (set_log), if it keeps one


def _load(path: Path, what: str) -> dict | None:
    try:
        data = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise DomainError(path, f"corrupt {what} ({type(e).__name__}); delete it to start over") from None
    if not isinstance(data, dict):
        raise DomainError(path, f"corrupt {what} (not a JSON object); delete it to start over")
    return data


def parts_dir(out) -> Path:
    """Where a job's per-sequence files go: OUT.parts/."""
    return Path(f"{out}.parts")


def part_path(out, seq_id: int) -> Path:
    return parts_dir(out) / f"seq-{seq_id:02d}.json"


def already_done(job: Job) -> set:
    """Sequences a finished OUT or OUT.partial.json of the same configuration holds (the runner keeps them);
    none with `force`, which plays every sequence again."""
    out, partial = Path(job.out), Path(f"{job.out}.partial.json")
    done: set = set()
    if job.force:
        return done
    if out.is_file():
        saved = _load(out, "results")
        diff = difference(saved, job.agent, job.model, job.protocol)
        if diff:
            raise DomainError(out, f"a finished run with {diff}; pass --force to play it again, or --out another file")
        done |= {int(i) for i in saved.get("sequences", [])}
    if partial.is_file():
        saved = _load(partial, "partial results")
        if difference(saved, job.agent, job.model, job.protocol) is None:
            done |= {int(i) for i in (saved.get("done") or {})}
    return done


def _reusable_part(job: Job, seq_id: int) -> dict | None:
    path = part_path(job.out, seq_id)
    if not path.is_file():
        return None
    try:
        part = _load(path, "sequence results")
    except DomainError:
        return None  # half a file: played again
    if (
        difference(part, job.agent, job.model, job.protocol) is None
        and part.get("sequence") == seq_id
        and isinstance(part.get("rows"), list)
    ):
        return part
    return None


# ---- the work item, in a worker ------------------------------------------------------------
_AGENTS: dict = {}


def play_item(item: dict) -> dict:
    """Play one canonical sequence with a freshly built (or this worker's cached) agent; its rows."""
    model = compile_domain(item["domain"], item["layout"])
    stream = item.get("stream", "iid")
    key = (item["agent"], repr(sorted(item["options"].items())), item["domain"], model.layout, stream)
    agent = _AGENTS.get(key)
    if agent is None:
        options = agent_options(item["agent"], **item["options"])
        agent = _AGENTS[key] = build(item["agent"], options, model)
        if stream != "iid":
            agent.on_stream(stream)
        if item.get("log") and agent.keeps_log:
            agent.set_log(item["log"])
    seq = load(model, [item["sequence"]], stream)[0]
    t0 = time.perf_counter()
    protocol = item.get("protocol", DEFAULT_PROTOCOL)
    rows = play_sequence(model, agent, seq, protocol=protocol)
    return {
        "agent": agent.name,
        **identity(model),
        "layout": model.layout,
        "config": agent.config,
        "failure_protocol": protocol,
        "sequence": seq.id,
        "rows": rows,
        "wall_seconds": round(time.perf_counter() - t0, 3),
    }


# ---- the driver ----------------------------------------------------------------------------
def play_over_workers(jobs: list, workers: int = 1, use_ray: bool = False, progress: bool = True) -> dict:
    """Play every job's missing sequences as work items; leave each job's rows in OUT.partial.json.

    Returns {"items": n played, "reused": n taken from OUT.parts, "wall": seconds,
    "played": the sequence ids played (over all jobs)}.
    """
    items, owners, reused = [], [], 0
    prov = provenance()
    for j, job in enumerate(jobs):
        done = already_done(job)
        for i in job.ids:
            if i in done:
                continue
            if not job.force and _reusable_part(job, i) is not None:
                reused += 1
                continue
            items.append(
                {
                    "agent": job.agent_name,
                    "options": asdict(job.options),
                    "domain": job.domain,
                    "layout": job.model.layout,
                    "sequence": i,
                    "log": job.log,
                    "protocol": job.protocol,
                    "stream": job.agent.config.get("stream", "iid"),
                }
            )
            owners.append(j)

    def write_part(k, result, meta):
        job = jobs[owners[k]]
        diff = difference(result, job.agent, job.model, job.protocol)
        if diff is not None:
            raise DomainError(job.out, f"a worker built the agent with {diff}")
        write_json(part_path(job.out, result["sequence"]), {**result, "provenance": {**prov, **meta}})

    t0 = time.perf_counter()
    run_items(
        play_item, items, workers=workers, use_ray=use_ray, on_result=write_part, progress=progress, desc="sequences"
    )
    for job in jobs:
        merge_parts(job)
    return {
        "items": len(items),
        "reused": reused,
        "wall": time.perf_counter() - t0,
        "played": sorted({item["sequence"] for item in items}),
    }


def merge_parts(job: Job) -> None:
    """Move a job's finished OUT.parts/ into OUT.partial.json (where the runner's evaluate finds them)."""
    folder = parts_dir(job.out)
    if not folder.is_dir():
        return
    partial = Path(f"{job.out}.partial.json")
    saved = _load(partial, "partial results") if partial.is_file() else None
    if saved is None or job.force or difference(saved, job.agent, job.model, job.protocol) is not None:
        saved = {
            "agent": job.agent.name,
            **identity(job.model),
            "layout": job.model.layout,
            "config": job.agent.config,
            "failure_protocol": job.protocol,
            "wall_seconds": 0.0,
            "done": {},
        }
    merged = []
    for i in job.ids:
        part = _reusable_part(job, i)
        if part is not None:
            saved["done"][str(i)] = part["rows"]
            saved["wall_seconds"] = saved.get("wall_seconds", 0.0) + part["wall_seconds"]
            prov = part.get("provenance") or {}
            saved.setdefault("provenance_of", {})[str(i)] = {
                "commit": prov.get("commit"),
                "date_utc": prov.get("written"),
                "host": prov.get("host"),
                "pid": prov.get("pid"),
            }
            merged.append(part_path(job.out, i))
    write_json(partial, saved)
    for path in merged:
        path.unlink(missing_ok=True)
    if not any(folder.iterdir()):
        folder.rmdir()

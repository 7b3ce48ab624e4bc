"""Reproduce the thesis's tables, figures and statistics from our results files, into one report.

    python -m experiments.reproduce [--layouts two-room,three-room] [--report-only] [--out docs/results.md]
    python -m experiments.reproduce --domain DIR [--layouts A,B] [--report-only] [--out FILE]

Without --report-only it first runs, through the agent registry and the
runner (`planning.world.runner.evaluate`: resumable, progress bars), every
evaluation a table row expects whose checkpoint exists and whose results file
does not (or is unfinished, or lacks sequences the row needs); runs another process
is writing, runs whose agent is not registered and runs without a checkpoint
are left, and listed with their commands. --discount-sweep also trains the
Table A.5 runs (long). Then, and alone with --report-only (well under a
minute), it writes the report (default docs/results.md) and its figures
(docs/figures/*.png beside it). The rows, files and commands are in
`experiments.report_specs`; which files are used and which are flagged is
`experiments.report_data`'s rule.

Any other domain folder (--domain; told apart by its PDDL define) gets the
report of `experiments.report_domain`: its own layouts (default: every layout
of the folder), the rows and tables that apply to any domain, and a list of
the thesis comparisons that do not; default output docs/results-<domain>.md,
no figures. A layout without its canonical sequences is named with the command
that writes them, and none of its runs is played.
"""
from __future__ import annotations

import argparse
import shlex
import subprocess
import sys
import time
from collections import defaultdict
from pathlib import Path

import numpy as np
from tqdm import tqdm

from experiments import report_domain
from experiments import report_figures as figs
from experiments import report_reference, report_tables
from experiments.report_data import (ALL, Context, last_commit, load_rows, load_run, read_jsonl, run_protocol,
                                     sha256, writer_pid)
from planning.atomic import read_json
from experiments.report_specs import (AGENTS, LAYOUTS, THESIS, THESIS_DISCOUNT, THESIS_MINIMAL, discount_runs,
                                      rl_run_dir, rows as row_specs, training_logs)
from planning import cli
from planning.atomic import write_json, write_text
from planning.errors import DomainError
from planning.parallel import results_provenance

NOTES = Path("docs/results-notes.md")
"""Hand-kept notes with no generator yet: included verbatim as the report's appendix."""


# ---- running what is missing ----------------------------------------------------------------
def needs_run(loaded, ids=ALL) -> bool:
    """True if reproduce should (re)run this run: missing, interrupted (no process writing it), or used but
    short of the sequences `ids`. A file made otherwise (another configuration, failure protocol or domain
    content) is not used and not replaced: that takes the run's command with --force."""
    if loaded.status == "not run":
        return True
    if loaded.status == "in progress":
        return writer_pid(loaded.run) is None
    if not loaded.used:
        return False
    have = {s["id"] for s in loaded.data["per_sequence"]}
    return bool(set(ids) - have)


def run_missing(rows, ctx: Context, ids=ALL, progress: bool = True, via: str = "") -> list[str]:
    """Evaluate every run of `rows` that `needs_run`, the myopic oracles first; returns the files written.

    Each written file's provenance names the run's own `experiments.evaluate` command and `via` (this command).
    """
    from oracles.command import reference_path
    from planning.world.runner import evaluate

    todo = [run for row in rows for run in row.runs if needs_run(load_run(run, ctx), ids)]
    todo.sort(key=lambda run: run.agent != "myopic-oracle")
    written = []
    for run in tqdm(todo, desc="runs", unit="run", disable=not progress):
        model, agent = ctx.model(run.layout), ctx.agent(run)
        if agent.keeps_log:
            agent.set_log(f"{run.out}.windows.jsonl")
        evaluate(model, agent, list(ids), run.out, progress=progress, reference=reference_path(model),
                 protocol=run_protocol(run))
        stamp(run, via)
        written.append(run.out)
    return written


def stamp(run, via: str) -> None:
    """Name the run's own command in its results file's provenance (the process was reproduce)."""
    data = read_json(run.out)
    prov = data.setdefault("provenance", {})
    prov.update(command=run.command, via=via)
    write_json(run.out, data)


def train_discount_sweep(progress: bool = True) -> None:
    """Train the Table A.5 runs that have not reached their last step (learning.dqn resumes its last.pt)."""
    from learning.dqn import Config

    for gamma, metrics, command in discount_runs():
        rows = curve(metrics)
        if rows and rows[-1]["step"] >= Config.steps:
            continue
        print(f"γ = {gamma:g}: {command}", file=sys.stderr)
        args = shlex.split(command)[1:]
        if not progress:
            args.append("--no-progress")
        subprocess.run([sys.executable, *args], check=True)


# ---- figures --------------------------------------------------------------------------------
def task_type(name: str) -> str:
    return name.split("(", 1)[0]


def by_task_type(rr) -> dict:
    """{task type: (mean cost, standard error)}: over seeds where there are two or more, else over tasks."""
    per_seed = []
    for d in rr.used:
        acc = defaultdict(list)
        for r in d["per_task"]:
            acc[task_type(r["task"])].append(r["cost"])
        per_seed.append(acc)
    out = {}
    for t in sorted({t for acc in per_seed for t in acc}):
        if len(per_seed) > 1:
            xs = [float(np.mean(acc[t])) for acc in per_seed if acc[t]]
        else:
            xs = [float(x) for x in per_seed[0][t]]
        sem = float(np.std(xs, ddof=1) / np.sqrt(len(xs))) if len(xs) > 1 else 0.0
        out[t] = (float(np.mean(xs)), sem)
    return out


FIGURE_A5_SEQUENCE = 0
A4_ROWS = ("myopic-oracle", *AGENTS, "clairvoyant-3")
A5_ROWS = ("myopic-oracle", *AGENTS, "clairvoyant-3")
A6_ROWS = ("myopic-oracle", "myopic-rl-guided", "gnn-augmented", "anticipatory-rl-guided")


def from_logs(draw, path: Path, logs: list[str]) -> tuple[Path | None, int]:
    """A figure drawn from training logs, which runs/ holds and git does not: where this checkout lacks some
    of the logs behind it and the committed PNG exists, that PNG is kept as it was drawn (a fresh checkout
    would otherwise redraw it from fewer runs, or drop it). Returns (PNG or None, logs missing here)."""
    missing = sum(not Path(p).is_file() for p in logs)
    if missing and path.is_file():
        return path, missing
    return draw(path), 0


def curve(log: str) -> list[dict]:
    """A training run's logged rows: the curve its results file keeps (`learning.export`), or its metrics.jsonl."""
    if log.endswith(".json"):
        data = read_json(log, "training results file")
        if not isinstance(data, dict) or not isinstance(data.get("curve"), list):
            raise DomainError(log, "a training results file without its curve (learning.export writes it)")
        return data["curve"]
    return [r for r in read_jsonl(log) if "step" in r]


def figures(results: dict, folder: Path) -> tuple[dict[str, tuple[Path | None, str]], dict[str, int]]:
    """{figure: (PNG or None, what it needs when None)}, every figure of the report, and {figure: training logs
    missing here} for those kept as committed (`from_logs`)."""
    from experiments.report_data import improvement

    f53 = {layout: {(h, d): (rows[f"{h}-rl-{d}"].figures() or {}).get("cost_seeds", [])
                    for h in ("myopic", "anticipatory") for d in ("greedy", "guided")} for layout, rows in results.items()}
    th53 = {layout: {(h, d): THESIS[layout][f"{h}-rl-{d}"]["cost"] for h in ("myopic", "anticipatory")
                     for d in ("greedy", "guided")} for layout in results}
    f54 = {layout: [(rows[k].row.label, improvement(rows[k], rows["myopic-oracle"]), THESIS[layout][k].get("improvement"))
                    for k in (*AGENTS, "clairvoyant-2", "clairvoyant-3", "clairvoyant-4")]
           for layout, rows in results.items()}
    fa4 = {layout: [(rows[k].row.label, [s["cost"] / s["tasks"] for d in rows[k].used for s in d["per_sequence"]])
                    for k in A4_ROWS] for layout, rows in results.items()}
    fa5 = {layout: [(rows[k].row.label, [[r["cost"] for r in sorted(d["per_task"], key=lambda r: r["index"])
                                          if r["sequence"] == FIGURE_A5_SEQUENCE] for d in rows[k].used])
                    for k in A5_ROWS] for layout, rows in results.items()}
    fa6 = {layout: {rows[k].row.label + ("" if len(rows[k].used) > 1 else " (SE over tasks: 1 seed)"): by_task_type(rows[k])
                    for k in A6_ROWS if rows[k].used} for layout, rows in results.items()}
    logs = {layout: {h: {s: curve(p) for s, p in training_logs(layout, h)} for h in ("myopic", "anticipatory")}
            for layout in results}
    a2, a2_logs = {}, []
    if "three-room" in results:
        seed0 = {h: f"{rl_run_dir(h, 'three-room', 0)}/metrics.jsonl" for h in ("anticipatory", "myopic")}
        a2_logs = [p for h, p in seed0.items() if Path(f"results/training-{h}-three-room-seed0.json").is_file()]
        a2 = {f"anticipatory, γ = {g:g}": curve(p) for g, p, _ in discount_runs()}
        a2["anticipatory, γ = 0.97 (main run)"] = curve(seed0["anticipatory"])
        a2["myopic"] = curve(seed0["myopic"])
    minimal = report_reference.read("results/minimal-example.json") or {}
    a1 = figs.training_curves(logs, folder / "fig-A-1-training.png")
    a2_png, a2_missing = from_logs(lambda path: figs.refill_share(a2, path), folder / "fig-A-2-refill-water.png", a2_logs)
    kept = {"A.2": a2_missing} if a2_missing else {}
    need_logs = "training logs `runs/dqn/restaurant-<layout>-<horizon>-seed<N>/metrics.jsonl` (`python -m learning.dqn ...`; runs/ is not committed)"
    return {
        "5.1b": (figs.minimal_example({h: minimal[h] for h in ("myopic", "anticipatory") if h in minimal},
                                      THESIS_MINIMAL, folder / "fig-5-1b-minimal-example.png"),
                 "`results/minimal-example.json` (`python -m experiments.minimal_example --out results/minimal-example.json`)"),
        "5.3": (figs.greedy_vs_guided(f53, th53, folder / "fig-5-3-greedy-vs-guided.png"),
                "the greedy and guided results files of Table A.4"),
        "5.4": (figs.improvement_bars(f54, folder / "fig-5-4-improvement.png"), "Table 5.2's results files"),
        "A.1": (a1, need_logs),
        "A.2": (a2_png, "three-room training logs (seed 0, the Table A.5 discounts: `--discount-sweep`)"),
        "A.4": (figs.sequence_distributions(fa4, folder / "fig-A-4-sequence-costs.png"), "Table 5.2's results files"),
        "A.5": (figs.cumulative_cost(fa5, FIGURE_A5_SEQUENCE, folder / "fig-A-5-cumulative-cost.png"),
                "Table 5.2's results files"),
        "A.6": (figs.cost_by_task_type(fa6, folder / "fig-A-6-task-types.png"), "the guided agents' results files"),
    }, kept


FIGURE_TEXT = {
    "5.1b": "Figure 5.1b: the minimal example's learned Q of the two task-1 placements (bars), the exact values by "
            "breadth-first search (black ticks) and the thesis's (open circles; its anticipatory ones are 9 + 0.99 V "
            "from its V_A ≈ 3.5, V_B ≈ 8.6).",
    "5.3": "Figure 5.3: greedy against value-guided deployment of the myopic and anticipatory values, both layouts. "
           "Points: mean over checkpoint seeds; bars: min–max over seeds; open squares: the thesis. Greedy costs "
           "include failed tasks, each completed by the fallback and charged what it executed plus its completion.",
    "5.4": "Figure 5.4: improvement over each layout's myopic oracle per agent, ours beside the thesis's.",
    "A.1": "Figure A.1: training diagnostics: success over the last 100 tasks, task return, selected Q and TD "
           "target; median over the seeds drawn with the min–max band. Every exported run of the learned rows' seeds "
           "is counted; a run is drawn from the curve its results file keeps, else from its `runs/` log where "
           "this checkout has one, and the legend gives the seeds drawn of all. Selected Q and TD target are on "
           "a symmetric log axis (linear within ±10) where a diverged run passes 1,000.",
    "A.2": "Figure A.2: share of all actions so far that are refill-water, over training (three-room, seed 0; cumulative since step 0, as the authors' code counts it).",
    "A.4": "Figure A.4: distribution of the mean cost per task of each 50-task sequence (every seed's), per agent, "
           "sorted by median; the clairvoyant oracle is K = 3.",
    "A.5": f"Figure A.5: cumulative cost over sequence {FIGURE_A5_SEQUENCE:02d} (50 tasks) per method: median over "
           "seeds, min–max band where there are several.",
    "A.6": "Figure A.6: mean cost per task type for the guided agents, the augmented GNN (where run) and the myopic "
           "oracle; error bars: standard error over seeds, or over the tasks of the type where a row has one seed.",
}


# ---- provenance -----------------------------------------------------------------------------
def config_summary(cfg: dict) -> str:
    skip = {"checkpoint", "search", "fallback", "eval", "note"}
    parts = [f"{k} {v:g}" if isinstance(v, float) else f"{k} {v}" for k, v in cfg.items()
             if k not in skip and isinstance(v, (int, float, str))]
    if isinstance(cfg.get("reference"), dict):
        parts.append(f"reference {cfg['reference'].get('planner')}")
    return ", ".join(parts)


def provenance_table(results: dict) -> list[str]:
    body = []
    for layout, rows in results.items():
        for rr in rows.values():
            for x in rr.loaded:
                if x.data is None:
                    continue
                prov = x.data.get("provenance") or {}
                commit = (f"`{prov['commit'][:10]}`" if prov.get("commit") else
                          f"not recorded (file last committed in {last_commit(x.run.out) or 'no commit'})")
                mach = prov.get("machine") or {}
                machine = f"{mach.get('host', '')} {mach.get('platform', '')}".strip() or "not recorded"
                ckpt = prov.get("checkpoint_sha256") or (sha256(x.run.checkpoint) if x.run.checkpoint else None)
                ckpt = (f"`{ckpt[:12]}`" + ("" if prov.get("checkpoint_sha256") else " (file now)")) if ckpt else "—"
                used = "used" if x.used else f"**not used**: {x.note}"
                body.append([f"`{Path(x.run.out).name}`", used, x.accounting or "—", commit,
                             prov.get("date_utc") or prov.get("written") or "not recorded", machine,
                             f"`{prov['command']}`" if prov.get("command") else
                             f"not recorded; the row's: `{x.run.command}`", config_summary(x.data.get("config") or {}),
                             ckpt, "; ".join([*(f"**{f}**" for f in x.flags), *x.notes]) or "—"])
    return report_tables.table(["results file", "use", "failed-task accounting", "commit", "date", "machine",
                                "command", "configuration", "checkpoint sha256", "flags (bold) and notes"], body)


# ---- Table A.5 ------------------------------------------------------------------------------
def discount_table() -> list[str]:
    body = []
    for gamma, metrics, command in discount_runs():
        rows = curve(metrics)
        jar, succ, q = THESIS_DISCOUNT[gamma]
        thesis = [pct_(jar), f"{succ:.3f}", f"{q:.1f}"]
        if not rows:
            body.append([f"{gamma:.2f}", f"not run (`{command}`)", "—", "—", *thesis])
            continue
        share = [r["action_share"].get("refill-water", 0.0) for r in rows if isinstance(r.get("action_share"), dict)]
        mean = lambda xs: float(np.nanmean(xs)) if xs else float("nan")
        body.append([f"{gamma:.2f}", f"{mean([r['success_rate'] for r in rows]):.3f} ({rows[-1]['step']:,} steps)",
                     f"{mean([r['selected_q'] for r in rows]):.1f}", pct_(mean(share), 2), *thesis])
    return report_tables.table(["γ", "training success (mean over the run)", "mean selected Q",
                                "refill-water share of actions", "thesis jar share of water deliveries",
                                "thesis success", "thesis mean Q"], body) + [
        "", "Three-room anticipatory, seed 0. `learning.dqn` logs the share of refill-water among all actions, not "
            "the jar's share of water deliveries the thesis tabulates (Figure A.2 plots the former), so the two "
            "columns are not the same measure. `--discount-sweep` trains these runs (each 500k steps)."]


def pct_(x, digits=1):
    return report_tables.pct(x, digits, False)


# ---- the report -----------------------------------------------------------------------------
def report(layouts, ctx: Context, out: Path, command: str) -> str:
    """Load every row, draw the figures, and return the report's markdown."""
    started = time.perf_counter()
    results = {layout: load_rows(row_specs(layout), ctx) for layout in layouts}
    folder = out.parent / "figures"
    drawn, kept = figures(results, folder)
    for old in folder.glob("fig-*.png"):          # a figure that can no longer be drawn is not left behind
        if old not in {path for path, _ in drawn.values()}:
            old.unlink()
    prov = results_provenance({})
    T = report_tables
    lines = [
        "# Measured results",
        "",
        "Generated by `python -m experiments.reproduce` from the results files under `results/`: do not edit by "
        "hand (hand-kept notes go to `docs/results-notes.md`, the appendix). Every figure names the results file "
        "it is read from (the provenance table at the end gives each file's commit, command, configuration, "
        "checkpoint hash, date and machine) and every missing run the command that would make it.",
        "",
        f"- commit: `{prov.get('commit') or 'unknown'}`"
        + (f" with uncommitted changes to {', '.join(prov['uncommitted_code'][:6])}" if prov.get("uncommitted_code") else ""),
        f"- command: `{command}`",
        f"- date: {prov['date_utc']}",
        f"- machine: {prov['machine']['host']}, {prov['machine']['platform']}, {prov['machine']['cpus']} CPUs, "
        f"Python {prov['machine']['python']}",
        "",
        "Conventions. Costs are PDDL cost units per task over the ten canonical 50-task sequences of a layout "
        "(500 tasks) unless a column says otherwise. A learned row is the mean ± sample standard deviation over "
        "its checkpoint seeds (a single seed shows no ±); *seeds* says how many of the thesis's seeds we have. "
        "*Improvement* is `(C_oracle − C) / C_oracle` against Fast Downward's myopic oracle on the same sequences. "
        "A failed task is completed by the fallback: its optimal completion from where it was left is executed, "
        "so the next task starts where a finished task would leave the world, and it is charged what it "
        "executed plus that completion (the rows marked *thesis protocol* abandon it instead, as the thesis "
        "did). †: a figure built on a flagged file; the flags are in the provenance table. The thesis draws its own "
        "canonical sequences and trains 500k steps, so its figures are a reference, not the same tasks.",
        "",
        "## Table 5.2: main results",
        "",
        *T.table_5_2(results),
        "## Table 5.3: the credit-horizon ablation (three-room)",
        "",
        *T.table_5_3(results),
        "",
        "## Table A.4: the learned values, greedy and guided",
        "",
        *T.table_a_4(results),
        "",
        "## Held-out seven against development three",
        "",
        "β of the guided agents was chosen on sequences 01, 03 and 06 (the development split, thesis Appendix "
        "A.1); the other seven are held out from that choice. Improvements are against the myopic oracle on the "
        "same split.",
        "",
        *T.held_out(results),
        "",
        "## Share of the clairvoyant saving",
        "",
        "`(C_myopic − C) / (C_myopic − C_clairvoyant-K)`: the part of the clairvoyant oracle's saving an agent "
        "recovers without seeing the future.",
        "",
        *T.clairvoyant_share(results),
        "",
        "## Statistics (thesis §5.4.3)",
        "",
        "Over sequences: each sequence's cost per task averaged over a row's seeds, paired by sequence, exact "
        "two-sided Wilcoxon signed-rank test (scipy; the smallest p at n = 10 is 0.002, at n = 7 0.0156). Across "
        "seeds: each seed's cost per task, Welch's t, and the 95% interval of the difference of means over B's "
        "mean (the interval of the reduction). The thesis's pair is Anticipatory RL (guided) against the "
        "augmented GNN; the other pairs are tested wherever both rows exist.",
        "",
        *T.statistics(results),
        "",
        "## Figures",
        "",
    ]
    for name, (path, needs) in drawn.items():
        if path is None:
            lines += [f"**Figure {name}**: not run (needs {needs}).", ""]
        else:
            lines += [f"![Figure {name}](figures/{path.name})", "", FIGURE_TEXT[name], ""]
            if name in kept:
                lines += [f"Kept as committed: drawn in a checkout that had its training logs; this one lacks "
                          f"{kept[name]} of them (`runs/` is not committed), so it was not redrawn.", ""]
    lines += ["## Table A.5: the discount sweep (optional)", "", *discount_table(), ""]
    ckpts = [str(p) for layout in layouts for h in ("myopic", "anticipatory")
             for p in sorted(Path("checkpoints").glob(f"rl-{h}-{layout}-seed*.pt"),
                             key=lambda p: (int(p.stem.split("-seed")[1].split("-")[0]), p.name))]
    for title, body in report_reference.everything(layouts, ckpts, sha256).items():
        lines += [f"## {title}", "", *body, ""]
    lines += ["## Runs not yet made", "", *T.missing_runs(results), "",
              "## Provenance of the results files", "", *provenance_table(results), ""]
    if NOTES.is_file():
        lines += ["## Appendix: hand-kept notes (not generated)", "",
                  f"Included verbatim from `{NOTES}`; each note names the results file it reads.", "",
                  NOTES.read_text().strip(), ""]
    lines += [f"<!-- generated in {time.perf_counter() - started:.1f} s -->", ""]
    return "\n".join(lines)


# ---- any other domain -----------------------------------------------------------------------
def is_thesis_domain(ctx: Context) -> bool:
    """True for the restaurant (its PDDL define) with the thesis's layouts: the report of the thesis applies."""
    from planning.domain.folder import layouts as folder_layouts

    known = folder_layouts(ctx.domain)
    return set(LAYOUTS) <= set(known) and ctx.model(LAYOUTS[0]).name == "restaurant"


def domain_rows(ctx: Context, layout: str) -> list:
    return report_domain.rows(ctx.domain, ctx.model(layout).name, layout)


def domain_report(layouts, ctx: Context, out: Path, command: str) -> str:
    """The report of a domain other than the restaurant (`experiments.report_domain`): its markdown."""
    started = time.perf_counter()
    name = ctx.model(layouts[0]).name
    results = {layout: load_rows(domain_rows(ctx, layout), ctx) for layout in layouts}
    prov = results_provenance({})
    D = report_domain
    summary = []
    for layout in layouts:
        m = ctx.model(layout)
        summary.append(f"- {layout}: {m.n_atoms} atoms, {m.n_actions} ground actions, {len(m.tasks)} task "
                       f"instances of {len({t.type for t in m.tasks})} types (`{Path(m.files['problem']).name}`)")
    lines = [
        f"# Measured results: {name}",
        "",
        f"Generated by `python -m experiments.reproduce --domain {ctx.domain}` from the results files under "
        "`results/`: do not edit by hand. Every missing run is listed with the command that would make it.",
        "",
        f"- commit: `{prov.get('commit') or 'unknown'}`"
        + (f" with uncommitted changes to {', '.join(prov['uncommitted_code'][:6])}" if prov.get("uncommitted_code") else ""),
        f"- command: `{command}`",
        f"- date: {prov['date_utc']}",
        f"- machine: {prov['machine']['host']}, {prov['machine']['platform']}, {prov['machine']['cpus']} CPUs, "
        f"Python {prov['machine']['python']}",
        "",
        "Conventions. Costs are PDDL cost units per task over the ten canonical 50-task sequences of a layout "
        "unless a column says otherwise. A learned row is the mean ± sample standard deviation over its "
        "checkpoint seeds. *Improvement* is `(C_oracle − C) / C_oracle` against Fast Downward's myopic oracle on "
        "the same sequences. A failed task is completed by the fallback, its optimal completion executed and "
        "charged (†: a figure built on a flagged file; the flags are in the provenance table).",
        "",
        "## Layouts",
        "",
        *summary,
        *D.sequences_note(ctx, layouts),
        "",
        "## Methods (Table 5.2's columns)",
        "",
        *D.methods(results),
        "## The learned values, greedy and guided (Table A.4's columns)",
        "",
        *D.learned(results),
        "",
        "## Held-out seven against development three",
        "",
        *D.held_out(results),
        "",
        "## Share of the clairvoyant saving",
        "",
        "`(C_myopic − C) / (C_myopic − C_clairvoyant-K)`: the part of the clairvoyant oracle's saving an agent "
        "recovers without seeing the future.",
        "",
        *D.clairvoyant_share(results),
        "",
        "## Statistics (thesis §5.4.3)",
        "",
        "Over sequences: each sequence's cost per task averaged over a row's seeds, paired by sequence, exact "
        "two-sided Wilcoxon signed-rank test. Across seeds: Welch's t and the 95% interval of the reduction.",
        "",
        *D.statistics(results),
        "",
        "## Not applicable to this domain",
        "",
        *(f"- {x}" for x in D.NOT_APPLICABLE),
        "",
        "## Runs not yet made",
        "",
        *report_tables.missing_runs(results),
        "",
        "## Provenance of the results files",
        "",
        *provenance_table(results),
        "",
        f"<!-- generated in {time.perf_counter() - started:.1f} s -->",
        "",
    ]
    return "\n".join(lines)


def playable(ctx: Context, layouts) -> list[str]:
    """The layouts whose canonical sequences exist (the others are named on stderr with their command)."""
    out = []
    for layout in layouts:
        folder = Path(ctx.domain) / "sequences" / layout
        if any(folder.glob("seq-*.json")):
            out.append(layout)
        else:
            print(f"{layout}: no canonical sequences in {folder}, nothing played (`python -m planning.world.sequences "
                  f"--domain {ctx.domain} --layout {layout}` writes them)", file=sys.stderr)
    return out


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--layouts", default=None, help="comma-separated layouts (default: the restaurant's "
                                                   f"{','.join(LAYOUTS)}; every layout of another domain's folder)")
    p.add_argument("--report-only", action="store_true", help="only read the results and write the report")
    p.add_argument("--out", default=None, type=cli.writable_file,
                   help="report (default: docs/results.md; docs/results-<domain>.md for another domain)")
    p.add_argument("--domain", default="domains/restaurant", help="domain folder (default: %(default)s)")
    p.add_argument("--discount-sweep", action="store_true", help="also train the Table A.5 runs (long)")
    p.add_argument("--no-progress", action="store_true")
    args = p.parse_args()
    ctx = Context(args.domain)
    thesis = is_thesis_domain(ctx)
    if thesis:
        known = list(LAYOUTS)
    else:
        from planning.domain.folder import layouts as folder_layouts

        known = folder_layouts(args.domain)
    layouts = [x for x in (args.layouts or ",".join(known)).split(",") if x]
    unknown = [x for x in layouts if x not in known]
    if unknown or not layouts:
        raise DomainError("--layouts", f"'{args.layouts}' names no known layout (known: {', '.join(known)})")
    if args.discount_sweep and not thesis:
        raise DomainError("--discount-sweep", f"trains the restaurant's Table A.5 runs, not {args.domain}'s")
    command = " ".join(["python -m experiments.reproduce", *map(shlex.quote, sys.argv[1:])])
    if not args.report_only:
        from planning.parallel import one_thread

        one_thread()
        rows = ([r for layout in layouts for r in row_specs(layout)] if thesis else
                [r for layout in playable(ctx, layouts) for r in domain_rows(ctx, layout)])
        written = run_missing(rows, ctx, progress=not args.no_progress, via=command)
        print(f"ran {len(written)} evaluations", file=sys.stderr)
        if args.discount_sweep:
            train_discount_sweep(not args.no_progress)
    start = time.perf_counter()
    if thesis:
        out = Path(args.out or "docs/results.md")
        write_text(out, report(layouts, ctx, out, command))
        print(f"wrote {out} and its figures in {time.perf_counter() - start:.1f} s")
    else:
        out = Path(args.out or f"docs/results-{ctx.model(layouts[0]).name}.md")
        write_text(out, domain_report(layouts, ctx, out, command))
        print(f"wrote {out} in {time.perf_counter() - start:.1f} s")


if __name__ == "__main__":
    cli.run(main)

"""The report of any domain folder but the restaurant: the rows and tables of the thesis that apply to it.

    python -m experiments.reproduce --domain domains/minimal [--layouts grid] [--report-only] [--out FILE]

The layouts are the folder's (domain.toml [layouts]). Per layout the rows are
those every domain has: the myopic oracle (Fast Downward, the reference of every
improvement) and ours, the clairvoyant oracle for K = 2 and 3, and the learned
values, greedy and guided, of each horizon: one run per Q-network checkpoint
`checkpoints/<domain>-rl-<horizon>-<layout>-seed<N>.pt` (the name `learning.export`
gives it; seed 0, not yet trained, where there is none); the one-task GNN rows only
where their models `checkpoints/<domain>-gnn-<variant>-<layout>-seed<N>.pt` exist. Results files have
the names `experiments.evaluate` gives them by default (the domain's name first).
The tables are Table 5.2's and Table A.4's columns without the thesis's, the
held-out split, the share of the clairvoyant saving and the §5.4.3 statistics
on the rows that exist, and the task-stream section (`experiments.report.streams`) where
the folder declares a stream; what only the restaurant has (the thesis's figures, the
three-room ablation of Table 5.3, the discount sweep of Table A.5, the
restaurant's reference tables) is named as not applicable. The domain's
hand-kept notes (`docs/results-<domain>-notes.md`), where it has some, close
the report verbatim, as `docs/results-notes.md` closes the restaurant's.
"""

from __future__ import annotations

import re
import time
from pathlib import Path

from experiments.report import provenance, streams, tables
from experiments.report.data import improvement, load_rows, read_finished
from experiments.report.specs import HORIZONS, LEAST_SEEDS, Row, Run, results_name, rl_seeds, rl_suffix
from experiments.report.tables import (
    HELD_OUT_HEADER,
    SHARE_TEXT,
    dagger,
    files_cell,
    held_out_cells,
    num,
    pct,
    pm,
    seeds_cell,
    share,
    status,
    table,
)
from planning.errors import DomainError

CLAIRVOYANT_K = (2, 3)
COMPARISONS = (
    ("anticipatory-rl-guided", "myopic-rl-guided"),
    ("anticipatory-rl-guided", "myopic-oracle"),
    ("anticipatory-rl-guided", "clairvoyant-2"),
    ("anticipatory-rl-greedy", "myopic-rl-greedy"),
    ("anticipatory-rl-guided", "gnn-augmented"),
    ("anticipatory-rl-guided", "gnn-augmented-bn"),
)
"""The pairs the statistics section tests where both rows exist (A against B)."""
ROW_KEYS = (
    "myopic-oracle",
    "myopic-oracle-internal",
    *(f"{h}-rl-{d}" for h in HORIZONS for d in ("greedy", "guided")),
    *(f"{g}{bn}" for g in ("gnn", "gnn-augmented") for bn in ("", "-bn")),
    *(f"clairvoyant-{K}" for K in CLAIRVOYANT_K),
)
"""Every row key a layout's tables may have (the GNN rows only where their models exist)."""
LEARNED = ("myopic-rl-greedy", "anticipatory-rl-greedy", "myopic-rl-guided", "anticipatory-rl-guided")
NOT_APPLICABLE = [
    "the thesis's figures and columns (its costs are the restaurant's);",
    "Table 5.3, the value–search ablation of the three-room restaurant;",
    "Table A.5, the discount sweep (three-room, seed 0);",
    "the restaurant's other reference tables: its labelling, trainer and GNN benchmarks, β selection and the "
    "thesis's minimal example (`python -m experiments.reproduce` reports them).",
]


def gnn_seeds(domain: str, layout: str, variant: str) -> list[int]:
    out = []
    for path in Path("checkpoints").glob(f"{domain}-gnn-{variant}-{layout}-seed*.pt"):
        m = re.fullmatch(rf"{re.escape(domain)}-gnn-{variant}-{re.escape(layout)}-seed(\d+)", path.stem)
        if m:
            out.append(int(m.group(1)))
    return sorted(out)


def rows(ctx, layout: str) -> list[Row]:
    """The rows of one layout of the domain folder `ctx.domain`, each run with its results file and command."""
    from oracles.clairvoyant import run_name  # the oracle's own file name; a heavy import, so here

    folder, domain = ctx.domain, ctx.model(layout).name
    d = ("--domain", folder)
    mark = rl_suffix(ctx.model(layout))  # the domain's task encoding, where not the thesis's

    def rl_run(agent, horizon, s):
        ckpt = f"checkpoints/{domain}-rl-{horizon}-{layout}-seed{s}{mark}.pt"
        train = (
            f"python -m learning.dqn --domain {folder} --layout {layout} --horizon {horizon} --seed {s} && "
            f"python -m learning.export runs/dqn/{domain}-{layout}-{horizon}-seed{s}{mark}"
        )
        return Run(
            agent,
            layout,
            (*d, "--checkpoint", ckpt),
            results_name(domain, f"{agent}-{horizon}-{layout}-seed{s}{mark}", layout),
            s,
            ckpt,
            train,
        )

    def gnn_run(agent, variant, s):
        model = f"checkpoints/{domain}-gnn-{variant}-{layout}-seed{s}.pt"
        return Run(
            agent,
            layout,
            (*d, "--model", model),
            results_name(domain, f"{agent}-{variant}-{layout}-seed{s}", layout),
            s,
            model,
            None,
        )

    out = [
        Row(
            "myopic-oracle",
            "Myopic oracle (Fast Downward)",
            layout,
            (Run("myopic-oracle", layout, d, results_name(domain, "myopic-oracle", layout)),),
        ),
        Row(
            "myopic-oracle-internal",
            "Myopic oracle (ours)",
            layout,
            (
                Run(
                    "myopic-oracle",
                    layout,
                    (*d, "--planner", "internal"),
                    results_name(domain, "myopic-oracle-internal", layout),
                ),
            ),
        ),
    ]
    for horizon in HORIZONS:
        seeds = sorted({*LEAST_SEEDS, *rl_seeds(domain, layout, horizon, mark)})
        for agent, deployment in (("rl-greedy", "greedy"), ("rl-guided", "guided")):
            out.append(
                Row(
                    f"{horizon}-rl-{deployment}",
                    f"{horizon.capitalize()} RL ({deployment})",
                    layout,
                    tuple(rl_run(agent, horizon, s) for s in seeds),
                    seeded=True,
                    template=rl_run(agent, horizon, "$N"),
                )
            )
    for variant, key, label in (
        ("faithful", "gnn", "One-task GNN"),
        ("augmented", "gnn-augmented", "One-task GNN (augmented)"),
    ):
        seeds = gnn_seeds(domain, layout, variant)
        if seeds:
            for agent, suffix, deployment in (
                ("gnn-native", "", "native selection"),
                ("gnn-guided", "-bn", "BN search"),
            ):
                out.append(
                    Row(
                        key + suffix,
                        f"{label}, {deployment}",
                        layout,
                        tuple(gnn_run(agent, variant, s) for s in seeds),
                        seeded=True,
                        template=gnn_run(agent, variant, "$N"),
                    )
                )
    for K in CLAIRVOYANT_K:
        out.append(
            Row(
                f"clairvoyant-{K}",
                f"Clairvoyant oracle (K = {K})",
                layout,
                (
                    Run(
                        "clairvoyant",
                        layout,
                        (*d, "--K", str(K), "--time-limit", "60"),
                        results_name(domain, run_name(K), layout),
                    ),
                ),
            )
        )
    return out


# ---- tables ---------------------------------------------------------------------------------
def methods(results: dict) -> list[str]:
    """Table 5.2's columns on every row: cost, improvement over the myopic oracle, success, seeds, files."""
    out = []
    for layout, rows_ in results.items():
        ref = rows_["myopic-oracle"]
        body = []
        for key, rr in rows_.items():
            f = rr.figures()
            if f is None:
                body.append([rr.row.label, status(rr), "—", "—", seeds_cell(rr), "—"])
                continue
            imp = "(reference)" if key == "myopic-oracle" else pct(improvement(rr, ref))
            succ = pm(100 * f["success"], 100 * f["success_std"] if f["success_std"] is not None else None) + "%"
            body.append(
                [rr.row.label, pm(f["cost"], f["cost_std"]) + dagger(rr), imp, succ, seeds_cell(rr), files_cell(rr)]
            )
        out += [f"### {layout}", ""]
        out += table(["method", "cost/task", "improvement", "success", "seeds", "results files"], body)
        out.append("")
    return out


def learned(results: dict) -> list[str]:
    """Table A.4's columns: the learned values, greedy and guided, with their steps per task."""
    body = []
    for layout, rows_ in results.items():
        for key in LEARNED:
            rr = rows_[key]
            f = rr.figures()
            horizon, _, deployment = key.partition("-rl-")
            if f is None:
                body.append([layout, deployment, horizon, status(rr), "—", "—", seeds_cell(rr)])
                continue
            sd = lambda k, s=1, f=f: f[f"{k}_std"] * s if f[f"{k}_std"] is not None else None
            body.append(
                [
                    layout,
                    deployment,
                    horizon,
                    pm(100 * f["success"], sd("success", 100)),
                    pm(f["steps"], sd("steps"), 2),
                    pm(f["cost"], sd("cost")) + dagger(rr),
                    seeds_cell(rr),
                ]
            )
    return table(["layout", "deployment", "horizon", "success %", "steps/task", "cost/task", "seeds"], body)


def held_out(results: dict) -> list[str]:
    body = [
        held_out_cells(layout, key, rr, rows_["myopic-oracle"])
        for layout, rows_ in results.items()
        for key, rr in rows_.items()
        if rr.figures() is not None
    ]
    return table(HELD_OUT_HEADER, body) if body else ["No results yet."]


def clairvoyant_share(results: dict) -> list[str]:
    body = []
    for layout, rows_ in results.items():
        ref = rows_["myopic-oracle"].figures()
        for key, rr in rows_.items():
            if key.startswith(("myopic-oracle", "clairvoyant")):
                continue
            f = rr.figures()
            if f is None or ref is None:
                body.append([layout, rr.row.label, status(rr), *["—"] * len(CLAIRVOYANT_K)])
                continue
            cells = []
            for K in CLAIRVOYANT_K:
                ck = rows_[f"clairvoyant-{K}"].figures(f["sequences"])
                cells.append(pct(share(ref["cost"], f["cost"], ck["cost"] if ck else None), 0, False))
            body.append([layout, rr.row.label + dagger(rr), pct(improvement(rr, rows_["myopic-oracle"])), *cells])
    return table(["layout", "method", "improvement", *(f"share of K = {K} saving" for K in CLAIRVOYANT_K)], body)


def tools(ctx, layouts) -> list[str]:
    """The domain's simulator and planner benchmarks and its reward calibration, a row per layout (each file
    as its command names it by default; "not run" with the command where it is missing)."""
    from learning.reward import calibration_path

    folder, body = ctx.domain, []
    for layout in layouts:
        model = ctx.model(layout)
        d = ("--domain", folder, "--layout", layout)
        sim_out, lab_out = (f"results/{model.name}-bench-{kind}-{layout}.json" for kind in ("simulator", "labelling"))
        files = {  # (file, module, options beyond --domain and --layout): the simulator and labelling benches name
            # no default file, so the report names theirs
            "sim": (sim_out, "planning.external.simulator_bench", ("--out", sim_out)),
            "planner": (results_name(model.name, "bench-planner", layout), "oracles.planner_bench", ()),
            "labelling": (lab_out, "oracles.labelling_bench", ("--states", "5", "--out", lab_out)),
            "calibration": (str(calibration_path(model)), "experiments.calibrate", ()),
        }
        got = {k: read_finished(path) for k, (path, _, _) in files.items()}
        todo = [f"`python -m {mod} {' '.join((*d, *extra))}`" for k, (_, mod, extra) in files.items() if got[k] is None]
        sim, plan, lab, cal = got["sim"], got["planner"], got["labelling"], got["calibration"]
        body.append(
            [
                layout,
                f"{num(sim['ratio_single'], 0)}× / {num(sim['ratio_batched'], 0)}×" if sim else "not run",
                (
                    f"{num(plan['ratio_total'], 1)}× over {plan['calls']} calls, "
                    f"{'equal' if plan['equal_costs'] else '**unequal**'} costs"
                )
                if plan
                else "not run",
                (
                    f"{num(lab['fast_downward']['seconds'] / lab['ours']['pdb']['seconds'], 1)}× over "
                    f"{lab['states']} states × {lab['tasks']} tasks, {'equal' if lab['equal_costs'] else '**unequal**'} "
                    "costs"
                )
                if lab and "pdb" in lab.get("ours", {}) and "fast_downward" in lab
                else "not run",
                f"{num(cal['d_max'], 2)}, {num(cal['r_goal'], 2)} (γ = {cal['gamma']})" if cal else "not run",
                "; ".join(todo) or "—",
            ]
        )
    return table(
        [
            "layout",
            "simulator vs unified-planning, single / batched",
            "our A* vs Fast Downward",
            "labelling oracle vs Fast Downward",
            "calibration D_max, R_goal",
            "missing: commands",
        ],
        body,
    )


CAPACITY_TEXT = (
    "`learning.capacity` fits the thesis's network, by regression and with the training's optimiser, to the "
    "optimal myopic Q (exact A* labels on the states of a persistent stream visited with random detours), then "
    "plays its greedy policy on the training's evaluation stream (100 tasks). A network that cannot fit Q* "
    "from exact labels will not learn it from rewards; one that fits its training states but not held-out ones "
    "needs more experience than the labels hold, or an encoding that generalises. Every check under "
    "`results/` is listed, this domain's first: the other domains' rows are the reference."
)


def capacity(ctx, layouts) -> list[str]:
    """Every capacity check under results/ (learning.capacity), this domain's first; the command of each of
    this domain's layouts without its default check."""
    from learning.capacity import default_out

    name = ctx.model(layouts[0]).name
    body = []
    for path in sorted(Path("results").glob("*capacity-*.json")):
        r = read_finished(path)
        if r is None or not r.get("fit"):
            continue
        s, last, g = r["settings"], r["fit"][-1], r["greedy"]
        body.append(
            (
                r["domain"] != name,
                [
                    r["domain"],
                    r["layout"],
                    f"{s['states']} / {s['epochs']} / {s['hidden']} / {s['task_features']}",
                    f"{num(100 * last['train_best_optimal'], 1)} / {num(100 * last['held_out_best_optimal'], 1)}",
                    num(last["held_out_l1"], 2),
                    num(100 * g["success_rate"], 0),
                    f"`{path}`",
                ],
            )
        )
    rows_ = [row for _, row in sorted(body, key=lambda b: b[0])]
    scored = scored_checkpoints(name)
    todo = [
        f"- not run: `python -m learning.capacity --domain {ctx.domain} --layout {layout}`"
        for layout in layouts
        if read_finished(default_out(ctx.model(layout))) is None
    ]
    if not rows_:
        return (todo or ["No results yet."]) + scored
    return [
        *table(
            [
                "domain",
                "layout",
                "states / epochs / width / task encoding",
                "best action optimal %, training / held out",
                "held-out L1 (RL units)",
                "greedy success %",
                "file",
            ],
            rows_,
        ),
        *([""] + todo if todo else []),
        *scored,
    ]


def scored_checkpoints(name: str) -> list[str]:
    """This domain's trained myopic checkpoints scored against Q* (`learning.capacity --score`): a table, or
    nothing."""
    body = []
    for path in sorted(Path("results").glob("*capacity-score-*.json")):
        r = read_finished(path)
        if r is None or r.get("domain") != name or not r.get("scored"):
            continue
        sc = r["scored"]
        body.append(
            [
                r["layout"],
                f"{r['run']}, step {r.get('checkpoint_step') or 0:,}",
                r.get("task_features", "arguments"),
                sc["pairs"],
                num(100 * sc["best_optimal"], 1),
                num(sc["l1"], 2),
                f"{num(sc['mean_q'], 2)} / {num(sc['mean_q_star'], 2)}",
                num(100 * r["greedy"]["success_rate"], 0),
                f"`{path}`",
            ]
        )
    if not body:
        return []
    return [
        "",
        "The trained values scored on the same kind of labels (`learning.capacity --score CHECKPOINT`, myopic "
        "checkpoints, labels with the run's discount and R_goal): a value that picks optimal actions but whose Q "
        "sits far below Q* has not yet grown to the returns; one that picks wrong ones is wrongly shaped.",
        "",
        *table(
            [
                "layout",
                "checkpoint",
                "task encoding",
                "(state, task) pairs",
                "best action optimal %",
                "L1 (RL units)",
                "mean Q / mean Q*",
                "greedy success %",
                "file",
            ],
            body,
        ),
    ]


TRAINING_TEXT = (
    "Each Q-learning run of this domain that `learning.export` has written a training file for. The greedy "
    "checks are the trainer's own (100 tasks of the evaluation stream, ε = 0, every `eval_every` steps): the "
    "learning curve by which a run's step count is judged. A run whose trained steps fall short of its "
    "configured ones is unfinished (still training, or stopped), and its checkpoint is its best check so far; "
    "a results file made with such a checkpoint is flagged (†)."
)


def notes_path(name: str) -> Path:
    """The domain's hand-kept notes (`docs/results-<domain>-notes.md`), the report's appendix where it exists."""
    return Path(f"docs/results-{name}-notes.md")


def rankings(name: str) -> list[str]:
    """How this domain's values rank labelled states by their exact C_AP, and what the exact C_AP would gain
    on gnn-native's candidates: the restaurant's two reference tables over this domain's results files."""
    from experiments.report.reference import native_candidates, value_ranking
    from planning.world.results import file_prefix

    prefix = file_prefix(name)
    if not any(Path("results").glob(f"{prefix}value-rank-*.json")):
        return [
            "Not measured yet: `python -m learning.values.rank --domain DOMAIN --data DATASET --value CKPT ...` "
            "(DATASET: a `learning.gnn_dataset` folder, e.g. `--augmented --n-states 100 --n-prepared 300`)."
        ]
    return [*value_ranking(prefix), *native_candidates(prefix)]


def training(ctx, layouts) -> list[str]:
    """A row per exported Q-learning run of this domain (results/<domain>-training-*.json) on `layouts`: its task
    encoding, steps trained of those configured, every greedy check and the training success."""
    name = ctx.model(layouts[0]).name
    body = []
    for path, d in ctx.trainings():
        if d.get("domain") != name or d.get("layout") not in layouts:
            continue
        cfg, at = d.get("config") or {}, d.get("at") or {}
        checks = d.get("greedy_checks") or [at[m]["greedy"] for m in sorted(at, key=int) if "greedy" in at[m]]
        planned = cfg.get("steps", d.get("steps"))
        best = d.get("best_greedy") or {}
        body.append(
            [
                f"`{path.name}`",
                d["layout"],
                d["horizon"],
                d.get("seed"),
                cfg.get("task_features") or "arguments",
                f"{d.get('steps', 0):,} of {planned:,}" + (" (unfinished)" if d.get("steps", 0) < planned else ""),
                ", ".join(f"{c['step'] // 1000}k {num(c['success_rate'], 2)}" for c in checks) or "—",
                " / ".join(
                    num(at[m]["success_last_100"], 2) if m in at else "—"
                    for m in ("50000", "100000", "250000", "500000")
                ),
                f"{num(best.get('success_rate'), 2)} at {best.get('step', 0):,}" if best else "—",
                num(d.get("train_hours"), 2),
            ]
        )
    if not body:
        return [f"No Q-learning run of {name} exported yet (`python -m learning.export runs/dqn/<run>`)."]
    return table(
        [
            "results file",
            "layout",
            "horizon",
            "seed",
            "task encoding",
            "steps trained",
            "greedy success at each check",
            "training success (last 100) at 50k / 100k / 250k / 500k",
            "best greedy check",
            "hours",
        ],
        body,
    )


BETA_TEXT = (
    "The guided agents' cost slack β is chosen as the thesis chose it (Appendix A.1, `experiments.select_beta`): "
    "each candidate played with one checkpoint on the development sequences 01, 03 and 06, the cheapest kept "
    "(ties: the smaller). domain.toml `[search]` beta is the chosen value; the held-out seven are free of the choice."
)


def beta_selection(ctx, layouts) -> list[str]:
    """This domain's β selections (results/beta-selection-*.json) on `layouts`: each candidate's development cost."""
    name = ctx.model(layouts[0]).name
    body = []
    for path in sorted(Path("results").glob("beta-selection-*.json")):
        r = read_finished(path)
        if r is None or r.get("domain") != name or r.get("layout") not in layouts:
            continue
        chosen = r.get("chosen_beta")
        cells = [
            f"{'**' if c['beta'] == chosen else ''}β {c['beta']:g}: {num(c['cost_per_task'], 1)}"
            f" ({num(100 * c['success_rate'], 0)}%){'**' if c['beta'] == chosen else ''}"
            for c in r.get("candidates", [])
        ]
        body.append([r["layout"], f"`{Path(r['checkpoint']).name}`", "; ".join(cells), f"{chosen:g}", f"`{path}`"])
    if not body:
        return [f"No β selection of {name} yet (`python -m experiments.select_beta --domain ... --checkpoint ...`)."]
    return table(["layout", "checkpoint", "development cost/task (success) per candidate", "chosen β", "file"], body)


PUBLISHED_KEYS = ("source", "what", "reduction", "layout", "ours", "protocol")
"""The keys of a domain.toml [[published]] entry (the module `published`)."""


def published(ctx, results: dict) -> list[str]:
    """The figures the literature published on this domain (domain.toml [[published]]), each beside ours.

    An entry gives its `source`, `what` it compares, the published `reduction` of the cost (a fraction), the
    `layout` of ours that corresponds, `ours`: the pairs [A, B] of the report's rows whose reduction 1 − A/B
    of the cost per task is ours (the row keys of the tables: myopic-oracle, anticipatory-rl-guided,
    gnn-augmented, gnn-augmented-bn, ...; [] where no row of ours does what it did), and how our `protocol`
    differs. The reduction is on the sequences both rows hold."""
    from planning.domain.folder import read_config

    where = Path(ctx.domain) / "domain.toml"
    entries = read_config(Path(ctx.domain)).get("published", [])
    body = []
    for i, e in enumerate(entries if isinstance(entries, list) else [entries]):
        missing = [k for k in PUBLISHED_KEYS if k not in e] if isinstance(e, dict) else list(PUBLISHED_KEYS)
        if missing:
            raise DomainError(where, f"[[published]] entry {i + 1} lacks {', '.join(missing)}")
        rows_ = results.get(e["layout"])
        if rows_ is None:
            raise DomainError(where, f"[[published]] entry {i + 1}: layout {e['layout']!r} is not reported")
        cells = []
        for pair in e["ours"]:
            unknown = [k for k in pair if k not in ROW_KEYS]
            if len(pair) != 2 or unknown:
                raise DomainError(where, f"[[published]] entry {i + 1}: {pair} is not a pair of row keys")
            a, b = pair
            if a not in rows_ or b not in rows_:  # a GNN row without its models
                cells.append(f"{a} vs {b}: not run")
                continue
            r = improvement(rows_[a], rows_[b])
            ours = pct(r) if r is not None else "not run"
            cells.append(f"{rows_[a].row.label} vs {rows_[b].row.label}: {ours}")
        body.append(
            [
                e["source"],
                e["what"],
                f"{-100 * e['reduction']:+.1f}%".replace("-", "−"),
                e["layout"],
                "; ".join(cells) or "no counterpart",
                e["protocol"],
            ]
        )
    if not body:
        return ["None declared (domain.toml [[published]])."]
    return table(["source", "what", "published cost change", "our layout", "ours (improvement)", "protocol"], body)


def sequences_note(ctx, layouts) -> list[str]:
    """One line per layout without its canonical sequences (no row can be played there yet)."""
    out = []
    for layout in layouts:
        folder = Path(ctx.domain) / "sequences" / layout
        if not any(folder.glob("seq-*.json")):
            out.append(
                f"- {layout}: no canonical sequences in `{folder}`: `python -m planning.world.sequences "
                f"--domain {ctx.domain} --layout {layout}` writes them (every row needs them)."
            )
    return out


# ---- the report -----------------------------------------------------------------------------
def report(layouts, ctx, command: str, folder: Path = Path("docs/figures")) -> str:
    """The report of `layouts` of the domain folder `ctx.domain`: its markdown (a drifting stream's figures drawn
    into `folder`)."""
    started = time.perf_counter()
    name = ctx.model(layouts[0]).name
    results = {layout: load_rows(rows(ctx, layout), ctx) for layout in layouts}
    stream_results = streams.load(ctx, layouts) if streams.declared(ctx, layouts) else {}
    stream_lines = (
        ["## Task streams: unknown, drifting and correlated", "", *streams.section(ctx, stream_results, folder), ""]
        if stream_results
        else []
    )
    no_streams = "the task-stream section: the folder declares no stream (domain.toml [streams.<name>]);"
    not_applicable = NOT_APPLICABLE if stream_results else [*NOT_APPLICABLE[:-1], no_streams, NOT_APPLICABLE[-1]]
    summary = []
    for layout in layouts:
        m = ctx.model(layout)
        summary.append(
            f"- {layout}: {m.n_atoms} atoms, {m.n_actions} ground actions, {len(m.tasks)} task "
            f"instances of {len({t.type for t in m.tasks})} types (`{Path(m.files['problem']).name}`)"
        )
    lines = [
        f"# Measured results: {name}",
        "",
        f"Generated by `python -m experiments.reproduce --domain {ctx.domain}` from the results files under "
        f"`results/`: do not edit by hand (hand-kept notes go to `{notes_path(name)}`, the appendix). Every missing "
        "run is listed with the command that would make it.",
        "",
        *provenance.header(command),
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
        *sequences_note(ctx, layouts),
        "",
        "## Methods (Table 5.2's columns)",
        "",
        *methods(results),
        "## The learned values, greedy and guided (Table A.4's columns)",
        "",
        *learned(results),
        "",
        "## Can the network hold the values? (a supervised check)",
        "",
        CAPACITY_TEXT,
        "",
        *capacity(ctx, layouts),
        "",
        "## How the values rank states (exact C_AP)",
        "",
        *rankings(name),
        "",
        "## Training runs: the learning curves",
        "",
        TRAINING_TEXT,
        "",
        *training(ctx, layouts),
        "",
        "## The search's β, chosen on the development split",
        "",
        BETA_TEXT,
        "",
        *beta_selection(ctx, layouts),
        "",
        "## Held-out seven against development three",
        "",
        *held_out(results),
        "",
        "## Share of the clairvoyant saving",
        "",
        SHARE_TEXT,
        "",
        *clairvoyant_share(results),
        "",
        "## Statistics (thesis §5.4.3)",
        "",
        "Over sequences: each sequence's cost per task averaged over a row's seeds, paired by sequence, exact "
        "two-sided Wilcoxon signed-rank test. Across seeds: Welch's t and the 95% interval of the reduction.",
        "",
        *tables.statistics(results, COMPARISONS, thesis=False),
        "",
        "## Benchmarks and reward calibration",
        "",
        "Ratios of one run each (`planning.external.simulator_bench`: successors per second of our simulator, "
        "one state at a time and batched, over unified-planning's SequentialSimulator on the same states, "
        "which must agree; `oracles.planner_bench`: Fast Downward's seconds over ours on one sequence's tasks, "
        "equal optimal costs checked; `oracles.labelling_bench`: the same for every task's cost from a state, one "
        "multi-goal search against a Fast Downward call per task) and the reward calibration (`experiments.calibrate`: R_goal = "
        "(1 + margin) × D_max over the internal myopic oracle's plans).",
        "",
        *tools(ctx, layouts),
        "",
        "## Published figures beside ours",
        "",
        "The literature's figures on this domain (domain.toml `[[published]]`) and ours that correspond. "
        "A positive improvement of ours is a cost reduction, as a published change of −x% is.",
        "",
        *published(ctx, results),
        "",
        *stream_lines,
        "## Not applicable to this domain",
        "",
        *(f"- {x}" for x in not_applicable),
        "",
        *provenance.closing(results, stream_results),
        *provenance.notes(notes_path(name)),
        f"<!-- generated in {time.perf_counter() - started:.1f} s -->",
        "",
    ]
    return "\n".join(lines)

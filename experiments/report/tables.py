"""The thesis's tables and statistics as markdown, from the loaded rows (`experiments.report.data`).

Every function takes `results[layout][row key] -> RowResult` and returns
markdown lines. A cell whose runs are missing says why ("not run", "in
progress", "not used") and the commands that would make them are listed once,
in `missing_runs`. A dagger (†) marks a figure built on a flagged results file
(the flags are in the provenance table).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from experiments import stats
from experiments.report.data import ALL, DEVELOPMENT, HELD_OUT, RowResult, curve, improvement, read_finished
from experiments.report.specs import (
    ABLATION,
    AGENTS,
    COMPARISONS,
    DISCOUNT_TRAIN,
    GAMMAS,
    LEARNED,
    SWEEP_SEEDS,
    TABLE_5_2,
    THESIS,
    THESIS_DISCOUNT,
    THESIS_HELD_OUT,
    THESIS_PROTOCOL,
    THESIS_SHARE_STATED,
    THESIS_STATS,
    discount_runs,
)

MISSING = "[commands](#runs-not-yet-made)"
SHARE_TEXT = (
    "`(C_myopic − C) / (C_myopic − C_clairvoyant-K)`: the part of the clairvoyant oracle's saving an agent "
    "recovers without seeing the future."
)
"""What the share of the clairvoyant saving is, as both reports introduce their table of it."""


# ---- formatting -----------------------------------------------------------------------------
def num(x, digits: int = 1) -> str:
    return "—" if x is None else f"{x:,.{digits}f}".replace("-", "−")


def pm(mean, std, digits: int = 1) -> str:
    """'mean ± std' (just the mean where there is no spread to give)."""
    return num(mean, digits) + (f" ± {num(std, digits)}" if std is not None else "")


def pct(x, digits: int = 1, sign: bool = True) -> str:
    if x is None:
        return "—"
    s = f"{100 * x:+.{digits}f}%" if sign else f"{100 * x:.{digits}f}%"
    return s.replace("-", "−")


def table(header: list[str], rows: list[list[str]]) -> list[str]:
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return out + ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]


def status(rr: RowResult) -> str:
    """Why a row has no figure: the most telling status among its runs."""
    states = [x.status for x in rr.loaded]
    if "in progress" in states:
        return f"in progress ({MISSING})"
    if "not used" in states:
        return f"not used: config differs ({MISSING})"
    if states and all(s == "agent not registered" for s in states):
        return f"not run: agent `{rr.row.runs[0].agent}` not registered ({MISSING})"
    return f"not run ({MISSING})"


def dagger(rr: RowResult) -> str:
    return " †" if rr.flagged else ""


def seeds_cell(rr: RowResult) -> str:
    used = [x.run.seed for x in rr.loaded if x.used]
    if not rr.row.seeded:
        return "—" if used else "0 of 1"
    return f"{len(used)} of {len(rr.loaded)}" + (f" (seed {', '.join(map(str, used))})" if used else "")


def files_cell(rr: RowResult) -> str:
    return "<br>".join(f"`{Path(x.run.out).name}`" for x in rr.loaded if x.used) or "—"


def thesis_cost(t: dict) -> str:
    return pm(t.get("cost"), t.get("cost_std"), 0) if t.get("cost") is not None else "—"


def thesis_success(t: dict) -> str:
    if t.get("success") is None:
        return "—"
    return pct(t["success"], 1, False) + (f" ± {100 * t['success_std']:.1f}" if t.get("success_std") else "")


# ---- Table 5.2 ------------------------------------------------------------------------------
def table_5_2(results: dict) -> list[str]:
    out = []
    for layout, rows in results.items():
        ref = rows["myopic-oracle"]
        body = []
        for key in TABLE_5_2:
            rr = rows[key]
            f = rr.figures()
            t = rr.row.thesis
            if f is None:
                ours = [status(rr), "—", "—"]
            else:
                imp = "(reference)" if key == "myopic-oracle" else pct(improvement(rr, ref))
                ours = [
                    pm(f["cost"], f["cost_std"]) + dagger(rr),
                    imp,
                    pm(100 * f["success"], 100 * f["success_std"] if f["success_std"] is not None else None) + "%",
                ]
            body.append(
                [
                    rr.row.label,
                    *ours,
                    seeds_cell(rr),
                    thesis_cost(t),
                    "—"
                    if t.get("improvement") is None
                    else ("— (0%)" if key == "myopic-oracle" else pct(t["improvement"])),
                    thesis_success(t),
                    files_cell(rr),
                ]
            )
        out += [f"### {layout}", ""]
        out += table(
            [
                "method",
                "cost/task",
                "improvement",
                "success",
                "seeds",
                "thesis cost/task",
                "thesis improvement",
                "thesis success",
                "results files",
            ],
            body,
        )
        out.append("")
    return out


# ---- Table 5.3 ------------------------------------------------------------------------------
def table_5_3(results: dict) -> list[str]:
    if "three-room" not in results:
        return ["Table 5.3 is a three-room ablation; the three-room layout was not asked for."]
    rows = results["three-room"]
    ref = rows["myopic-oracle"]
    body, cost = [], {}
    for key, label in ABLATION:
        rr = rows[key]
        f = rr.figures()
        t = THESIS["three-room"][key]
        cost[key] = f["cost"] if f else None
        body.append(
            [
                label,
                status(rr) if f is None else pm(f["cost"], f["cost_std"]) + dagger(rr),
                "—" if f is None else pct(improvement(rr, ref)),
                seeds_cell(rr),
                thesis_cost(t),
                pct(t.get("improvement")),
                files_cell(rr),
            ]
        )
    out = table(
        [
            "configuration",
            "cost/task",
            "improvement",
            "seeds",
            "thesis cost/task",
            "thesis improvement",
            "results files",
        ],
        body,
    )
    value = (
        cost["gnn-augmented-bn"] - cost["anticipatory-rl-guided"]
        if None not in (cost["gnn-augmented-bn"], cost["anticipatory-rl-guided"])
        else None
    )
    search = (  # against the native selection of the authors' generator
        cost["gnn-augmented-focused"] - cost["gnn-augmented-bn"]
        if None not in (cost["gnn-augmented-focused"], cost["gnn-augmented-bn"])
        else None
    )
    out += [
        "",
        f"Holding the search fixed, the anticipatory value accounts for "
        f"{num(value) if value is not None else 'a reduction not yet measurable (not run)'} "
        f"(thesis 209); the search, holding the GNN value fixed, for "
        f"{num(search) if search is not None else 'a reduction not yet measurable (not run)'} (thesis 121).",
    ]
    return out


# ---- Table A.4 ------------------------------------------------------------------------------
def table_a_4(results: dict) -> list[str]:
    body = []
    for layout, rows in results.items():
        for key in (*LEARNED, *THESIS_PROTOCOL):
            if key not in rows:
                continue
            rr = rows[key]
            f = rr.figures()
            t = rr.row.thesis
            horizon, _, deployment = key.partition("-rl-")
            deployment = deployment.replace("greedy-abandon", "greedy, failed tasks abandoned (thesis protocol)")
            if f is None:
                ours = [status(rr), "—", "—"]
            else:
                sd = lambda k, s=1, f=f: f[f"{k}_std"] * s if f[f"{k}_std"] is not None else None
                ours = [
                    pm(100 * f["success"], sd("success", 100)),
                    pm(f["steps"], sd("steps"), 2),
                    pm(f["cost"], sd("cost")) + dagger(rr),
                ]
            body.append(
                [
                    layout,
                    deployment,
                    horizon,
                    *ours,
                    seeds_cell(rr),
                    pm(100 * t["success"], 100 * t["success_std"]),
                    pm(t["steps"], t["steps_std"], 2),
                    thesis_cost(t),
                ]
            )
    return table(
        [
            "layout",
            "deployment",
            "horizon",
            "success %",
            "steps/task",
            "cost/task",
            "seeds",
            "thesis success %",
            "thesis steps/task",
            "thesis cost/task",
        ],
        body,
    ) + [
        "",
        "A failed task (its 64 actions spent) is completed by the fallback in our rows: its optimal "
        "completion is executed and charged, and the next task starts where a finished task would leave "
        "the world. The thesis abandoned it instead (the world stays as left, the executed cost only); the "
        "rows marked *thesis protocol* replay the same checkpoints that way, for comparison with its "
        "figures. Under that protocol a row claims no improvement over the myopic oracle unless every "
        "task succeeded.",
    ]


# ---- held-out seven vs development three ----------------------------------------------------
HELD_OUT_HEADER = [
    "layout",
    "method",
    "development 01, 03, 06",
    "held-out seven",
    "all ten",
    "improvement, development",
    "improvement, held-out",
]


def held_out_cells(layout: str, key: str, rr: RowResult, ref: RowResult) -> list:
    """A row's cells of HELD_OUT_HEADER: its cost per task on each split and its improvement over the
    reference (the myopic oracle's row, `key` "myopic-oracle") on the two halves."""
    dev, held, every = rr.figures(DEVELOPMENT), rr.figures(HELD_OUT), rr.figures(ALL)
    return [
        layout,
        rr.row.label + dagger(rr),
        num(dev["cost"]) if dev else "—",
        num(held["cost"]) if held else "—",
        num(every["cost"]) if every else "—",
        "(reference)" if key == "myopic-oracle" else pct(improvement(rr, ref, DEVELOPMENT)),
        "(reference)" if key == "myopic-oracle" else pct(improvement(rr, ref, HELD_OUT)),
    ]


def held_out(results: dict) -> list[str]:
    body = []
    for layout, rows in results.items():
        for key in TABLE_5_2:
            if rows[key].figures() is None:
                continue
            thesis = THESIS_HELD_OUT.get(layout, {}).get(key)
            body.append(
                [*held_out_cells(layout, key, rows[key], rows["myopic-oracle"]), num(thesis, 0) if thesis else "—"]
            )
    return table(
        [*HELD_OUT_HEADER, "thesis held-out"],
        body,
    )


# ---- share of the clairvoyant saving ---------------------------------------------------------
def share(c_myo, c, c_k):
    return None if None in (c_myo, c, c_k) or c_myo == c_k else (c_myo - c) / (c_myo - c_k)


def clairvoyant_share(results: dict) -> list[str]:
    body = []
    for layout, rows in results.items():
        ref = rows["myopic-oracle"].figures()
        for key in AGENTS:
            rr = rows[key]
            f = rr.figures()
            if f is None or ref is None:
                body.append([layout, rr.row.label, status(rr), "—", "—", "—", _thesis_share(layout, key)])
                continue
            cells = []
            for K in (2, 3, 4):
                ck = rows[f"clairvoyant-{K}"].figures(f["sequences"])
                cells.append(pct(share(ref["cost"], f["cost"], ck["cost"] if ck else None), 0, False))
            body.append(
                [
                    layout,
                    rr.row.label + dagger(rr),
                    pct(improvement(rr, rows["myopic-oracle"])),
                    *cells,
                    _thesis_share(layout, key),
                ]
            )
    return table(
        [
            "layout",
            "method",
            "improvement",
            "share of K = 2 saving",
            "share of K = 3 saving",
            "share of K = 4 saving",
            "thesis share of K = 3 saving",
        ],
        body,
    )


def _thesis_share(layout: str, key: str) -> str:
    t = THESIS[layout]
    stated = THESIS_SHARE_STATED.get((layout, key, 3))
    if stated is not None:
        return f"{pct(stated, 0, False)} (stated)"
    s = share(t["myopic-oracle"]["cost"], t[key].get("cost"), t["clairvoyant-3"].get("cost"))
    return f"{pct(s, 0, False)} (from Table 5.2)" if s is not None else "—"


# ---- statistics (§5.4.3) --------------------------------------------------------------------
def shared_seeds(ra: RowResult, rb: RowResult) -> tuple[list, list, list] | None:
    """(seeds, A's results, B's results) of the seeds both rows used, where their seed sets differ and share
    some: a comparison free of the luck of the seeds only one side has. None where the sets are equal or
    disjoint (an oracle's row has no seed)."""
    sa = {x.run.seed: x.data for x in ra.loaded if x.used}
    sb = {x.run.seed: x.data for x in rb.loaded if x.used}
    both = sorted(set(sa) & set(sb) - {None})
    if not both or set(sa) == set(sb):
        return None
    return both, [sa[s] for s in both], [sb[s] for s in both]


def statistics(results: dict, comparisons=COMPARISONS, thesis: bool = True, same_seeds: bool = False) -> list[str]:
    """The §5.4.3 tests of each pair (A against B) both of whose rows a layout has: Wilcoxon over
    sequences, Welch across seed means; with `thesis`, the thesis's figures beside ours; with
    `same_seeds`, the tests again on the seeds both rows have, where their seed sets differ (`shared_seeds`)."""
    body = []
    for layout, rows in results.items():
        for a, b in comparisons:
            if a not in rows or b not in rows:
                continue
            ra, rb = rows[a], rows[b]
            label = f"{ra.row.label} vs {rb.row.label}"
            # (label, sequences, A's results, B's results, the thesis's figures of the same test)
            known = THESIS_STATS.get((layout, a, b), {})
            splits = [
                ("all ten", ALL, ra.used, rb.used, known.get("all", {})),
                ("held-out seven", HELD_OUT, ra.used, rb.used, known.get("held-out", {})),
            ]
            shared = shared_seeds(ra, rb) if same_seeds else None
            if shared is not None:  # the thesis reports no test on a subset of its seeds
                seeds = ", ".join(str(s) for s in shared[0])
                splits.append((f"all ten, seeds {seeds} only", ALL, shared[1], shared[2], {}))
            for split, ids, used_a, used_b, th in splits:
                theirs = [_thesis_stats(th)] if thesis else []
                if not ra.used or not rb.used:
                    missing = " and ".join(r.row.label for r in (ra, rb) if not r.used)
                    body.append([layout, label, split, f"not run ({missing}: {MISSING})", "—", "—", "—", "—", *theirs])
                    continue
                res = stats.compare(used_a, used_b, ids)
                w, t = res["wilcoxon"], res["welch"]
                wil = f"W = {w['statistic']:g}, p = {w['p']:.4g}" if "p" in w else w["reason"]
                welch = (
                    f"t({t['df']:.1f}) = {t['t']:.2f}, p = {t['p']:.3g}; 95% CI "
                    f"{pct(t['ci'][0], 1, False)} to {pct(t['ci'][1], 1, False)}"
                    if "t" in t
                    else t["reason"]
                )
                body.append(
                    [
                        layout,
                        label + (dagger(ra) or dagger(rb)),
                        split,
                        f"{w['a_cheaper']} of {w['n']}",
                        wil,
                        pct(t["reduction"]) if t.get("reduction") is not None else "—",
                        welch,
                        f"{t['n_a']} / {t['n_b']}",
                        *theirs,
                    ]
                )
    header = [
        "layout",
        "A vs B",
        "sequences",
        "A cheaper on",
        "Wilcoxon (exact, two-sided)",
        "reduction 1 − A/B (seed means)",
        "Welch's t across seeds",
        "seeds A / B",
    ]
    return table(header + (["thesis"] if thesis else []), body)


def _thesis_stats(th: dict) -> str:
    parts = []
    if "a_cheaper" in th:
        parts.append(f"{th['a_cheaper']} of {th['n']}")
    if "wilcoxon_p" in th:
        parts.append(f"p = {th['wilcoxon_p']}")
    if "reduction" in th:
        parts.append(f"reduction {pct(th['reduction'], 1, False)}")
    if "t" in th:
        parts.append(
            f"t({th['df']}) = {th['t']}, p = {th['welch_p']}, CI {pct(th['ci'][0], 1, False)}–"
            f"{pct(th['ci'][1], 1, False)}"
        )
    return "; ".join(parts) or "—"


# ---- Table A.5 ------------------------------------------------------------------------------
def discount_figures(run, prep) -> dict:
    """One sweep run's figures (`specs.DiscountRun`): over its training curve (the exported one, else the log
    of a run still training) the mean success of the last 100 tasks and the mean selected Q; the greedy and
    guided cost per task; the preparation's share of deliveries in the guided plans (`prep`, the layout's
    [preparation]). A figure the run lacks is absent."""
    out: dict = {}
    trained = read_finished(run.training)
    rows = trained.get("curve") if trained else curve(run.log)
    if rows:
        out.update(
            steps=rows[-1]["step"],
            exported=trained is not None,
            success=float(np.mean([r["success_rate"] for r in rows])),
            q=float(np.mean([r["selected_q"] for r in rows])),
        )
    for kind, path in (("greedy", run.greedy), ("guided", run.guided)):
        data = read_finished(path)
        if data and data.get("cost_per_task") is not None:
            out[kind] = data["cost_per_task"]
            if kind == "guided" and prep is not None:
                out["jar"] = prep.share(data.get("per_task", []), path)[0]
    return out


def _spread(figs: list[dict], key: str, fmt) -> str:
    xs = [f[key] for f in figs if f.get(key) is not None]
    if not xs:
        return "—"
    cell = fmt(float(np.mean(xs))) + (f" ± {fmt(float(np.std(xs, ddof=1)))}" if len(xs) > 1 else "")
    return cell + ("" if len(xs) == len(figs) else f" ({len(xs)} of {len(figs)})")


def discount_table(prep) -> list[str]:
    """Table A.5 beside the thesis's: per discount, the sweep's seeds (`specs.discount_runs`) as mean ± std.
    `prep`: the three-room layout's [preparation] (`planning.world.preparation`), what a delivery from the jar is."""
    runs = discount_runs()
    body, missing = [], []
    for gamma in GAMMAS:
        mine = [r for r in runs if r.gamma == gamma]
        figs = [discount_figures(r, prep) for r in mine]
        jar, succ, q = THESIS_DISCOUNT[gamma]
        trained = [f for f in figs if "steps" in f]
        done = [f for f in trained if f["exported"]]
        training = [f"{f['steps']:,}" for f in trained if not f["exported"]]
        state = f"{len(done)} of {len(mine)}" + (f"; in training: {', '.join(training)} steps" if training else "")
        body.append(
            [
                f"{gamma:.2f}",
                state,
                _spread(figs, "success", lambda x: f"{x:.3f}"),
                _spread(figs, "q", lambda x: f"{x:.1f}"),
                _spread(figs, "greedy", lambda x: num(x)),
                _spread(figs, "guided", lambda x: num(x)),
                _spread(figs, "jar", lambda x: pct(x, 1, False)),
                pct(jar, 1, False),
                f"{succ:.3f}",
                f"{q:.1f}",
            ]
        )
        missing += [r for r, f in zip(mine, figs) if "guided" not in f]
    lines = table(
        [
            "γ",
            "seeds exported",
            "training success (mean over the run)",
            "mean selected Q (over the run)",
            "greedy cost/task",
            "guided cost/task",
            "jar share of water deliveries (guided plans)",
            "thesis jar share",
            "thesis success",
            "thesis mean Q",
        ],
        body,
    ) + [
        "",
        f"Three-room anticipatory, seeds {', '.join(map(str, SWEEP_SEEDS))} per discount (mean ± std over the "
        "seeds; the thesis's rows are seed 0), each discount's seeds trained in one process with their "
        "updates batched (`learning.q.seeds`); γ = 0.97 is retrained alike, so every row comes from the same "
        "pipeline. Training success and selected Q are means over the exported training curve (a row every "
        "5,000 steps), as the thesis's Succ column is a mean over the whole run. The jar share is measured in "
        "the guided agent's executed plans over the ten canonical sequences (the domain's [preparation] "
        "deliveries: refill-water against fills of anything but the jar); the thesis's is measured over "
        "training, exploration included, so the two columns are not the same protocol.",
    ]
    if missing:
        lines += [
            "",
            f"Not yet made: {len(missing)} of {len(runs)} runs. Training, export and greedy evaluation: "
            f"`{DISCOUNT_TRAIN}` (`python -m experiments.reproduce --discount-sweep` runs it and the guided "
            "evaluations); each guided evaluation:",
            "",
            *[f"- `{r.evaluate}`" for r in missing],
        ]
    return lines


# ---- what is missing ------------------------------------------------------------------------
def missing_runs(results: dict) -> list[str]:
    """Every run a row expects that is not used, why, and the commands that would make it (a seeded row's
    missing seeds of one kind as one shell loop over its template)."""
    out = []
    for layout, rows in results.items():
        for rr in rows.values():
            groups: dict = {}
            for x in rr.loaded:
                if not x.used:
                    groups.setdefault(x.status, []).append(x)
            for state, xs in groups.items():
                train = state == "no checkpoint"
                if rr.row.template is not None and len(xs) > 1:
                    seeds = [x.run.seed for x in xs]
                    t = rr.row.template
                    body = " && ".join([*([t.train] if train and t.train else []), t.command])
                    out.append(f"- **{rr.row.label}** ({layout}), seeds {', '.join(map(str, seeds))}: {state}")
                    out.append(f"  - `for N in {' '.join(map(str, seeds))}; do {body}; done`")
                    continue
                for x in xs:
                    seed = f", seed {x.run.seed}" if x.run.seed is not None else ""
                    out.append(f"- **{rr.row.label}** ({layout}{seed}): {state}: {x.note}")
                    if train and x.run.train:
                        out.append(f"  - train: `{x.run.train}`")
                    out.append(f"  - evaluate: `{x.run.command}`")
    return out or ["Every run the tables expect has a results file."]

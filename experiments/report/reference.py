"""The report's reference tables beyond the thesis's: planners, clairvoyant windows, checkpoints, the minimal
example, reward calibration, β selection and the benchmarks, each generated from its results file.

Each function returns markdown lines; a missing file is one line naming the
command that writes it. Times come from a shared machine: ratios are taken
within one file.
"""

from __future__ import annotations

import math
from pathlib import Path

from experiments.report.data import mean_std
from experiments.report.data import read_finished as read
from experiments.report.specs import CLAIRVOYANT_K, LAYOUTS, THESIS, THESIS_MINIMAL, clairvoyant_run
from experiments.report.tables import num, pct, table


def missing(path, command) -> list[str]:
    return [f"Not run: `{path}` does not exist (`{command}`)."]


def nearest_rank(xs: list[float], q: float) -> float | None:
    """The nearest-rank q-quantile."""
    xs = sorted(xs)
    return xs[max(0, math.ceil(q * len(xs)) - 1)] if xs else None


def oracle_planners(layouts) -> list[str]:
    body = []
    for layout in layouts:
        ref = read(f"results/myopic-oracle-{layout}.json")
        for name, path in (
            ("Fast Downward, blind A*", f"results/myopic-oracle-{layout}.json"),
            ("ours, A* with pattern databases", f"results/myopic-oracle-internal-{layout}.json"),
        ):
            d = read(path)
            if d is None:
                body.append([name, layout, "not run", "—", "—", "—", "—", f"`{Path(path).name}`", "—"])
                continue
            imp = (
                "(reference)"
                if "internal" not in path
                else (pct((ref["cost_per_task"] - d["cost_per_task"]) / ref["cost_per_task"], 2) if ref else "—")
            )
            body.append(
                [
                    name,
                    layout,
                    num(d["cost_per_task"], 2),
                    num(d["actions_per_task"], 3),
                    pct(d["success_rate"], 1, False),
                    imp,
                    num(d["wall_seconds"]),
                    f"`{Path(path).name}`",
                    num(THESIS[layout]["myopic-oracle"]["cost"], 0) if "Fast" in name else "",
                ]
            )
    return table(
        [
            "planner",
            "layout",
            "cost/task",
            "actions/task",
            "success",
            "improvement",
            "wall s",
            "results file",
            "thesis cost/task",
        ],
        body,
    ) + [
        "",
        "`python -m experiments.evaluate --agent myopic-oracle --layout L [--planner internal]` (or "
        "`python -m oracles.myopic`). Both planners are optimal; among equal-cost plans they may pick "
        "different ones, after which the worlds drift apart slightly.",
    ]


def clairvoyant_windows(layouts) -> list[str]:
    body = []
    for K in CLAIRVOYANT_K:
        for layout in layouts:
            path = clairvoyant_run(K, layout).out
            d = read(path)
            if d is None:
                body.append([K, layout, "not run", "—", "—", "—", "—", "—", f"`{Path(path).name}`"])
                continue
            secs = [r["window_seconds"] for r in d["per_task"] if r.get("window_seconds") is not None]
            bounded = d.get("bounded_windows", 0)
            body.append(
                [
                    K,
                    layout,
                    num(d["cost_per_task"]),
                    num(d["actions_per_task"], 3),
                    f"{pct(d.get('share_optimal'), 1, False)} of {d.get('windows')}",
                    f"{bounded} ({pct(d.get('bounded_mean_gap') or 0, 1, False)})" if bounded else "0",
                    f"{num(nearest_rank(secs, 0.5), 2)} / {num(nearest_rank(secs, 0.9), 1)} / "
                    f"{num(max(secs) if secs else None, 1)}",
                    num(d["wall_seconds"]),
                    f"`{Path(path).name}`",
                ]
            )
    return table(
        [
            "K",
            "layout",
            "cost/task",
            "actions/task",
            "optimal windows",
            "bounded (mean gap)",
            "median / p90 / max s per window",
            "wall s",
            "results file",
        ],
        body,
    ) + [
        "",
        "*Optimal*: share of the planned windows solved optimally (by A*, or by a myopic chain that met the "
        "proven lower bound); *bounded*: windows cut off by the time limit (60 s), with the mean gap "
        "`1 − lower bound / chain cost`. Percentiles are nearest-rank over the rows that planned a window. "
        "The thesis solves K ≥ 3 with a satisficing planner at 600 s per window (its costs are upper bounds). "
        "At K = 4 a window the pattern databases leave unproven in 60 s is searched again with the grown "
        "patterns (`--heuristic pdb,pdb-grown`); its seconds count both searches and their tables' "
        "building. Per-window records: each results file's `.windows.jsonl`.",
    ]


def checkpoints(paths: list[str], sha) -> list[str]:
    """A row per Q-network checkpoint, with the training results file that names it (what made it)."""
    from learning.q.checkpoints import checkpoint_config

    made = {
        d["checkpoint"]: (f.name, d)
        for f in sorted(Path("results").glob("training-*.json"))
        if (d := read(f)) is not None and d.get("checkpoint")
    }
    body = []
    for path in paths:
        if not Path(path).is_file():
            continue
        cfg = checkpoint_config(path)
        ev = cfg.get("eval", {})
        name, figures = made.get(path, (None, {}))
        by = (
            f"`{name}`: `{figures.get('run', '—')}`, exported at `{(figures.get('provenance') or {}).get('commit', '')[:10]}`"
            if name
            else "no training results file names it"
        )
        body.append(
            [
                f"`{path}`",
                cfg.get("horizon", "—"),
                cfg.get("seed", "—"),
                f"{cfg.get('step', 0):,}",
                pct(ev.get("success_rate"), 0, False),
                cfg.get("gamma", "—"),
                f"`{(sha(path) or '')[:16]}`",
                by,
            ]
        )
    return table(
        ["checkpoint", "horizon", "seed", "step", "100-task check", "γ", "sha256 (first 16)", "made by"], body
    ) + [
        "",
        "*Step*: the training step of the kept checkpoint; *100-task check*: the trainer's greedy evaluation "
        "that selected it; *made by*: the training results file that names the checkpoint, its run folder and "
        "the commit it was exported at (the run's settings are in the training table). The thesis's checkpoints "
        "come from 500k-step runs.",
    ]


def minimal_example() -> list[str]:
    d = read("results/minimal-example.json")
    if d is None:
        return missing(
            "results/minimal-example.json", "python -m experiments.minimal_example --out results/minimal-example.json"
        )
    body = []
    for h in ("myopic", "anticipatory"):
        o, t = d[h], THESIS_MINIMAL[h]
        body.append(
            [
                h,
                num(o["q_A"], 3),
                num(o["q_B"], 3),
                num(o["gap"], 3),
                pct(o["share_B"], 1, False),
                num(o.get("exact_gap"), 3),
                f"{num(t['gap'], 2)}, {pct(t['share_B'], 0, False)}",
            ]
        )
    return table(["horizon", "Q(A)", "Q(B)", "gap", "share on B", "exact gap", "thesis gap, share on B"], body) + [
        "",
        f"{d['myopic']['steps']:,} training steps per agent, seed {d['myopic']['config']['seed']}; share on B "
        f"by softmax over Q ({d['softmax']['episodes']:,} episodes, temperature {d['softmax']['temperature']}). "
        "`results/minimal-example.json` (`python -m experiments.minimal_example --out "
        "results/minimal-example.json`).",
    ]


def calibration(layouts) -> list[str]:
    body = []
    for layout in layouts:
        d = read(f"results/calibration-{layout}.json")
        if d is None:
            body.append([layout, "not run", "—", "—", "—", "—"])
            continue
        th = d.get("thesis") or {}
        body.append(
            [
                layout,
                f"{d['completed_plans']:,} ({d['auto']})",
                num(d["d_max"], 2),
                f"`{d['argmax']['task']}`",
                num(d["r_goal"], 2),
                f"{num(th.get('d_max'), 2)}, {num(th.get('r_goal'), 2)}",
            ]
        )
    return table(
        ["layout", "plans (auto-completed)", "D_max", "plan with D_max", "R_goal", "thesis D_max, R_goal"], body
    ) + [
        "",
        "`python -m experiments.calibrate --layout L` (2,000 tasks of the internal myopic "
        "oracle, γ = 0.95, R_goal = 1.2 × D_max). The thesis calibrated with a satisficing "
        "planner, whose plans cost at least as much as optimal ones.",
    ]


def beta_selection(layouts) -> list[str]:
    out = []
    for layout in layouts:
        for path in sorted(Path("results").glob(f"beta-selection-rl-*-{layout}-seed*.json")):
            d = read(path)
            if d is None:
                continue
            body = [
                [
                    f"{c['beta']:g}",
                    num(c["cost_per_task"]),
                    pct(c["success_rate"], 1, False),
                    pct(c.get("improvement_vs_myopic")),
                    f"`{Path(c['file']).name}`",
                ]
                for c in d["candidates"]
            ]
            out += [
                f"`{path}` ({d['checkpoint']}): chosen β = {d['chosen_beta']:g} on sequences {d['development']}.",
                "",
            ]
            out += table(["β", "development cost/task", "success", "improvement", "results file"], body) + [""]
            for split, s in (d.get("final") or {}).get("splits", {}).items():
                out.append(
                    f"- {split}: cost per task {num(s['cost_per_task'])}, improvement "
                    f"{pct(s.get('improvement_vs_myopic'))}"
                )
            out.append("")
    return out or [
        "Not run: no `results/beta-selection-*.json` (`python -m experiments.select_beta --layout "
        "three-room --checkpoint checkpoints/rl-anticipatory-three-room-seed0.pt`). The thesis chose "
        "β = 3.0 on the three-room restaurant from {1.25, 3, 6, 8}."
    ]


def benchmarks() -> list[str]:
    out = ["### Simulator", ""]
    d = read("results/bench-three-room.json")
    if d is None:
        out += missing("results/bench-three-room.json", "make bench")
    else:
        out += table(
            ["simulator", "successors/s", "ratio to unified-planning"],
            [
                ["ours, `successors(state)`", f"{d['successors_per_s']:,}", f"{d['ratio_single']}x"],
                [
                    f"ours, batched numpy step (batch {d['batch_size']:,})",
                    f"{d['batched_transitions_per_s']:,}",
                    f"{d['ratio_batched']}x",
                ],
                ["unified-planning `SequentialSimulator`", num(d["reference_successors_per_s"]), "1x"],
            ],
        )
        out += [
            "",
            f"`results/bench-three-room.json` (`make bench`): {d['states']} reachable {d['layout']} states, "
            f"{d['successors']:,} successors (mean branching {d['mean_branching']}); machine "
            f"{d.get('machine', '—')}.",
        ]
    out += ["", "### Planner", ""]
    d = read("results/bench-planner-two-room.json")
    if d is None:
        out += missing("results/bench-planner-two-room.json", "python -m oracles.planner_bench --layout two-room")
    else:
        out += [
            f"`results/bench-planner-two-room.json` (`python -m oracles.planner_bench --layout two-room`): the "
            f"first {d['calls']} (state, task) pairs of sequence {d['sequence']}, costs equal: "
            f"{d['equal_costs']}. Ours {num(d['ours_seconds'])} s against Fast Downward's "
            f"{num(d['fast_downward_seconds'])} s: {d['ratio_total']}x in total, {d['ratio_per_call_median']}x "
            f"per call at the median, {d['ratio_per_call_min']}x at the least."
        ]
    out += ["", "### Labelling", ""]
    body = []
    for path in sorted(Path("results").glob("bench-labelling-*.json")):
        d = read(path)
        if d is None:
            continue
        for name, o in d["ours"].items():
            ratio = o.get("ratio_vs_fast_downward")
            body.append(
                [
                    f"`{path.name}`",
                    f"ours, {name}",
                    d["states"],
                    num(o["states_per_s"], 3),
                    num(o.get("setup_seconds"), 2),
                    num(o["max_state_seconds"], 2),
                    f"{ratio}x Fast Downward" if ratio else "",
                ]
            )
        fd = d.get("fast_downward")
        if fd:
            body.append(
                [
                    f"`{path.name}`",
                    f"Fast Downward, {fd['calls']} calls in {num(fd['seconds'], 2)} s",
                    d["states"],
                    num(fd["states_per_s"], 4),
                    "",
                    "",
                    f"costs equal: {d.get('equal_costs')}",
                ]
            )
    out += table(["results file", "labeller", "states", "states/s", "set-up s", "slowest state s", "ratio"], body)
    out += [
        "",
        "`python -m oracles.labelling_bench --layout three-room --states 20 [--heuristic pdb,lmcut] "
        "[--no-fast-downward]`.",
    ]
    out += ["", "### Trainer", ""]
    body, notes = [], []
    for layout in LAYOUTS:
        d = read(f"results/dqn-bench-{layout}.json")
        if d is None:
            notes += missing(f"results/dqn-bench-{layout}.json", f"python -m learning.q.bench --layout {layout}")
            continue
        for h in ("myopic", "anticipatory"):
            for regime in ("early", "competent"):
                r = d[h][regime]
                body.append(
                    [
                        layout,
                        h,
                        regime,
                        num(d[h].get(f"train_steps_per_s_{regime}")),
                        num(r["updates_per_s"], 1),
                        num(r["update_ms"], 2),
                        " / ".join(f"{k} {v}" for k, v in r.get("parts_ms", {}).items()),
                        pct(r.get("boundary_share"), 0, False) if "boundary_share" in r else "",
                        f"{pct(r['matmul_share'], 0, False)} at {num(r['matmul_gflops'], 1)} GFLOPS"
                        if "matmul_share" in r
                        else "not measured",
                    ]
                )
        notes += [
            "",
            f"`results/dqn-bench-{layout}.json` (`python -m learning.q.bench --layout {layout} --steps "
            f"{d['steps']} --updates {d['updates']}`), {d['threads']} thread, CPU time; machine "
            f"{d.get('machine', '—')}.",
        ]
    out += (
        table(
            [
                "layout",
                "horizon",
                "regime",
                "training steps/s",
                "updates/s",
                "ms/update",
                "parts (ms)",
                "boundary share",
                "matrix products",
            ],
            body,
        )
        if body
        else []
    )
    out += [
        "",
        "A training step is one ε = 0.05 acting step and one update of batch 128 (the thesis's ratio); "
        "the target is 140 steps/s, a 500k-step run in an hour.",
    ] + notes
    out += seeds_together()
    out += gnn_datasets()
    out += ["", "### GNN estimator", ""]
    body, maes = [], {}
    for path in sorted(Path("results").glob("bench-gnn-*.json")):
        d = read(path)
        if d is None:
            continue
        v, i, e = d["validation"], d["inference"], d["exact"]
        run = read(f"results/training-{Path(d['model']['model']).stem}.json") or {}
        maes.setdefault(d["layout"], []).append(v["mae"])
        body.append(
            [
                f"`{path.name}`",
                d["layout"],
                d["model"].get("seed"),
                d["model"].get("epoch"),
                num(run.get("seconds_per_epoch"), 2),
                v["states"],
                num(v["mae"], 1),
                num(v["exact_mean"], 0),
                num(v["spearman"], 3),
                pct(v["pair_agreement"], 1, False),
                num(i["c_ap_ms"], 1),
                f"{num(i['encode_ms'], 1)} / {num(i['forward_ms'], 1)}",
                num(e["per_state_ms"], 0),
                f"{e['ratio_to_gnn']}x",
            ]
        )
    out += table(
        [
            "results file",
            "layout",
            "seed",
            "best epoch",
            "s/epoch",
            "validation states",
            "MAE",
            "mean C_AP",
            "Spearman",
            "pairs ordered right",
            "batch of 50, ms",
            "encode / forward ms",
            "exact C_AP ms/state",
            "exact / GNN per state",
        ],
        body,
    )
    for layout, xs in maes.items():
        m, sd = mean_std(xs)
        out += [
            "",
            f"{layout}: validation MAE {num(m, 1)} ± {num(sd, 1)} over {len(xs)} seeds (each seed its own split).",
        ]
    out += [
        "",
        "`python -m learning.gnn.bench --model checkpoints/gnn-<variant>-<layout>-seed<N>.pt --data "
        "runs/gnn/<layout>-<variant>`: the model on its own run's validation split; the exact C_AP is the "
        "labelling oracle's. The authors' three-room runs reached a validation L1 of about 50. *s/epoch*: "
        "the training run's (`results/training-gnn-*.json`), at whatever load the machine had.",
    ]
    return out + native_candidates()


def seeds_together() -> list[str]:
    """Several seeds trained in one process (`learning.q.bench --seeds S`): their aggregate updates/s against one
    seed alone, beside the most batching could give while the matrix products keep their rate. S seeds do S times
    the arithmetic; if everything else were shared, S updates would cost S·m + (1 − m) single updates, m the
    matrix products' share of one update in the layout's single-seed benchmark (competent regime, as here)."""
    body, notes = [], []
    for layout in LAYOUTS:
        path = f"results/dqn-bench-seeds-{layout}.json"
        d = read(path)
        if d is None:
            continue
        single = read(f"results/dqn-bench-{layout}.json") or {}
        for h, r in d["seeds"].items():
            m = single.get(h, {}).get("competent", {}).get("matmul_share")
            S = r["seeds"]
            body.append(
                [
                    layout,
                    h,
                    S,
                    num(r["single_updates_per_s"], 1),
                    num(r["aggregate_updates_per_s"], 1),
                    f"{r['ratio']:.2f}×",
                    "not measured" if m is None else f"{S / (S * m + 1 - m):.2f}× (m = {pct(m, 0, False)})",
                ]
            )
        command = (d.get("provenance") or {}).get("command", "python -m learning.q.bench --seeds S")
        notes.append(f"`{path}` (`{command}`), {d['threads']} thread, CPU time, alternating rounds.")
    if not body:
        return []
    head = ["layout", "horizon", "seeds", "one seed: updates/s", "in one process: updates/s in all", "ratio", "ceiling"]
    return [
        "",
        "Seeds trained together in one process (`learning.q.seeds`, the competent regime): the ratio of their "
        "aggregate updates/s to one seed's; the ceiling is what batching could give if everything but the matrix "
        "products were shared and they kept their rate, S / (S·m + 1 − m) with m their share of one update above: "
        "batching saves only the rest of an update, and the products above already run at tens of GFLOPS.",
        "",
        *table(head, body),
        "",
        *notes,
    ]


def gnn_datasets() -> list[str]:
    """The GNN datasets' key figures (`learning.export` of a learning.gnn_dataset folder)."""
    body = []
    for path in sorted(Path("results").glob("dataset-gnn-*.json")):
        d = read(path)
        if d is None:
            continue
        k, c, cfg = d["kinds"], d["c_ap"], d.get("config", {})
        body.append(
            [
                f"`{path.name}`",
                d["layout"],
                d["variant"],
                f"{d['states']:,}",
                " / ".join(f"{k.get(x, 0):,}" for x in ("faithful", "prepared")),
                num(c["mean"], 1),
                f"{num(c['min'], 0)} – {num(c['max'], 0)}",
                cfg.get("heuristic", "—"),
                num(d.get("label_cpu_seconds"), 0),
                num(d.get("seconds_collecting_and_labelling"), 0),
            ]
        )
    if not body:
        return []
    return (
        ["", "### GNN datasets", ""]
        + table(
            [
                "results file",
                "layout",
                "variant",
                "states",
                "faithful / prepared",
                "mean C_AP",
                "C_AP range",
                "labelling heuristic",
                "labelling CPU s",
                "wall s",
            ],
            body,
        )
        + [
            "",
            "`python -m learning.gnn_dataset --layout <layout> [--augmented] --n-states 2000 --out "
            "runs/gnn/<layout>-<variant>` builds a dataset (graphs and exact one-task C_AP labels; megabytes, not "
            "committed); `python -m learning.export runs/gnn/<layout>-<variant>` writes its key figures. *Labelling "
            "CPU s*: the sum of every label's own search time, labels taken from another folder (`--reuse-labels`, "
            "as the augmented sets took the faithful ones) included; *wall s*: this build's collecting and "
            "labelling.",
        ]
    )


def native_candidates(prefix: str = "") -> list[str]:
    """The GNN's estimate on the candidates gnn-native scored, against their exact C_AP (runs with --exact-labels);
    prefix: the results files' domain prefix (`results_file`: "" for the restaurant, "blockworld-")."""
    from learning.agents.gnn_native import candidate_accuracy

    body = []
    for path in sorted(Path("results").glob(f"{prefix}gnn-native-*.json")):
        d = read(path)
        a = candidate_accuracy(d.get("per_task", [])) if d else None
        if a is None:
            continue
        seconds = [r["seconds"] for r in d["per_task"] if "seconds" in r]
        cfg = d.get("config") or {}
        generator = (cfg.get("candidate_generator") or {}).get("kind", "clause-library")
        body.append(
            [
                f"`{path.name}`",
                d["layout"],
                f"{generator}, {cfg.get('joint_heuristic', '—')}",
                a["tasks"],
                a["candidates"],
                num(a["mae"], 1),
                num(a["spearman"], 3),
                pct(a["within_task_pairs_right"], 1, False),
                pct(a["same_choice_as_exact"], 1, False),
                num(a["mean_excess"], 1),
                pct(a["exact_departs"], 1, False),
                num(a["exact_gain"], 1),
                num(sum(seconds) / len(seconds) if seconds else None, 1),
            ]
        )
    if not body:
        return []
    return (
        ["", "### GNN estimate on the candidates gnn-native scored", ""]
        + table(
            [
                "results file",
                "layout",
                "candidates, planned with",
                "tasks",
                "candidates",
                "MAE",
                "Spearman",
                "pairs in a task ordered right",
                "same choice as exact C_AP",
                "mean excess",
                "exact C_AP leaves the myopic plan",
                "exact gain",
                "s/task (incl. labels)",
            ],
            body,
        )
        + [
            "",
            "An evaluation run with `--exact-labels` labels every scored candidate's end state with the exact C_AP "
            "(oracles.labelling); these end states are not checked against the GNN's training states, so MAE and "
            "Spearman may count states it learned from. *Same choice*: cost + exact C_AP picks the candidate "
            "cost + Ĉ_AP picked; *mean "
            "excess*: how much more the chosen candidate's cost + exact C_AP is than the best one's, per task (PDDL "
            "units). *Exact C_AP leaves the myopic plan*, *exact gain*: the same rule with exact labels on the "
            "same candidates: how often it would leave the myopic plan, and its mean saving in cost + C_AP over the "
            "myopic plan per scored task (PDDL units). s/task counts the candidate planning (once per state and "
            "task; later runs read the shared candidate cache) and the exact labels. *Planned with*: the candidate "
            "generator and the admissible heuristic of the augmented candidates' searches (`--joint-heuristic`; "
            "the same costs, another optimal plan where several tie).",
        ]
    )


def training_runs() -> list[str]:
    """Appendix A.2's figures of each run (`results/training-*.json`, written by learning.export)."""
    body = []
    for path in sorted(Path("results").glob("training-*.json")):
        d = read(path)
        if d is None or "horizon" not in d:  # a GNN run's figures go with the GNN estimator's table
            continue
        at = d.get("at", {})
        cell = lambda m, k, digits=2, at=at: num(at[m][k], digits) if m in at and at[m].get(k) is not None else "—"
        best = d.get("best_greedy") or {}
        body.append(
            [
                f"`{path.name}`",
                d.get("layout"),
                d.get("horizon"),
                d.get("seed"),
                " / ".join(str(d.get(k, "—")) for k in ("eps_schedule", "explore", "demo_planner"))
                + ("" if d.get("target_bound", "none") == "none" else f" / target bound {d['target_bound']}"),
                f"{d.get('steps', 0):,}",
                " / ".join(cell(m, "success_last_100") for m in ("50000", "100000", "250000", "500000")),
                cell(str(max(map(int, at), default=0)), "selected_q", 1),
                cell(str(max(map(int, at), default=0)), "td_target", 1),
                cell(str(max(map(int, at), default=0)), "refill_share", 4),
                f"{num(best.get('success_rate'), 2)} at {best.get('step', 0):,}",
                num(best.get("demo_q_bias"), 2) if "demo_q_bias" in best else "",
                num(d["peak_selected_q"]["selected_q"], 1),
                pct((d.get("peak_refill_share") or {}).get("share"), 2, False)
                + " / "
                + pct((d.get("peak_refill_share_cumulative") or {}).get("share"), 2, False),
                num(d.get("train_hours"), 2),
                num(d.get("steps_per_s_median"), 0),
            ]
        )
    if not body:
        return [
            "No finished run exported yet: `python -m learning.export runs/dqn/<run>` writes "
            "`results/training-<horizon>-<layout>-seed<N>.json` and the compact checkpoint."
        ]
    return table(
        [
            "results file",
            "layout",
            "horizon",
            "seed",
            "ε schedule / exploration / demonstrations",
            "steps",
            "success (last 100) at 50k / 100k / 250k / 500k",
            "selected Q",
            "TD target",
            "refill share",
            "best greedy check",
            "demo_q_bias",
            "peak selected Q",
            "peak refill share (window / cumulative)",
            "hours",
            "steps/s (median)",
        ],
        body,
    ) + [
        "",
        "Selected Q, TD target and the share of refill-water actions are the last log window's (1,000 steps); "
        "Appendix A.2 (seed medians): success at the end two-room 0.95 anticipatory / 0.97 myopic, three-room "
        "0.93 / about 0.5; selected Q two-room about 233 / 57, three-room about 170 / 70; refill-water share "
        "(three-room, γ = 0.97) peaks at 1.34% (cumulative since step 0, as the authors' code counts it). "
        "Settings: the authors' (time-constant / factored / clairvoyant-3 for an anticipatory run) or this "
        "project's earlier ones (reach / uniform / internal); see docs/design.md. "
        "`python -m learning.export runs/dqn/<run>` writes each file with the run's compact checkpoint.",
    ]


def target_bound_runs() -> list[str]:
    """Each run trained with a target bound (`learning.dqn --target-bound`) beside its twin with the thesis's
    targets: the same layout, horizon and seed (`results/training-*-bound-*.json`)."""
    body = []
    for path in sorted(Path("results").glob("training-*-bound-*.json")):
        bounded = path.stem[len("training-") :]
        for name in (bounded[: bounded.index("-bound-")], bounded):
            d = read(f"results/training-{name}.json") or {}
            greedy, guided = read(f"results/rl-greedy-{name}.json"), read(f"results/rl-guided-{name}.json")
            last = (d.get("at") or {}).get("500000", {})
            body.append(
                [
                    d.get("layout", "—"),
                    d.get("horizon", "—"),
                    d.get("seed", "—"),
                    d.get("target_bound", "none"),
                    num((d.get("peak_selected_q") or {}).get("selected_q"), 1),
                    num(last.get("success_last_100"), 2),
                    pct(greedy["success_rate"], 1, False) if greedy else "not run",
                    num(greedy["cost_per_task"], 1) if greedy else "—",
                    num(guided["cost_per_task"], 1) if guided else "not run",
                    pct(guided["improvement_vs_myopic"], 1) if guided else "—",
                ]
            )
    if not body:
        return [
            "No run with a target bound exported yet (`python -m learning.dqn --target-bound return`, then "
            "`python -m learning.export runs/dqn/<run>-bound-return`)."
        ]
    return table(
        [
            "layout",
            "horizon",
            "seed",
            "target bound",
            "peak selected Q",
            "success (last 100) at 500k",
            "greedy success",
            "greedy cost/task",
            "guided cost/task",
            "guided vs myopic oracle",
        ],
        body,
    ) + [
        "",
        "`return` caps each TD target at the largest return a task can earn (R_goal for a myopic value, "
        "R_goal/(1−γ) for an anticipatory one); the thesis has no cap, so its tables use the runs without one. "
        "Greedy and guided: the ten canonical sequences (`results/rl-greedy-*.json`, `results/rl-guided-*.json`).",
    ]


def value_ranking(prefix: str = "") -> list[str]:
    """Rank agreement of each value's V_AP with the exact -C_AP (`results/<prefix>value-rank-*.json`,
    learning.values.rank); prefix as `native_candidates`'."""
    body, spreads = [], []
    for path in sorted(Path("results").glob(f"{prefix}value-rank-*.json")):
        d = read(path)
        c = (d or {}).get("c_ap")
        if c:
            spreads.append(
                f"- `{path.name}`: the states' exact C_AP, mean {num(c['mean'], 1)} ± {num(c['std'], 1)} "
                f"(std), from {num(c['min'], 1)} to {num(c['max'], 1)}"
            )
        for row in (d or {}).get("values", []):
            a = row["all"]
            kinds = "; ".join(f"{k}: {num(b.get('spearman'), 3)}" for k, b in row.get("by_kind", {}).items())
            body.append(
                [
                    f"`{path.name}`",
                    d["layout"],
                    f"`{row['value']}`",
                    f"{a['states']:,}" + (f" ({row['scored_on']})" if row.get("scored_on") else ""),
                    num(a.get("spearman"), 3),
                    num(a.get("kendall"), 3),
                    pct(a.get("pair_agreement"), 1, False),
                    num(a.get("slope_rl_per_pddl"), 4),
                    kinds or "—",
                ]
            )
    if not body:
        return [
            "Not measured yet: `python -m learning.values.rank --data runs/gnn/<layout>-faithful --value CKPT ...`."
        ]
    return table(
        [
            "results file",
            "layout",
            "value",
            "states",
            "Spearman",
            "Kendall",
            "pairs ordered right",
            "slope (RL per PDDL unit)",
            "Spearman by kind",
        ],
        body,
    ) + [
        "",
        "The states of a GNN dataset with their exact one-task C_AP (labelling oracle); each value's V_AP against "
        "−C_AP. The search uses a value only to rank the terminal states it reaches, so this is the property "
        "that matters to it. A one-task value's slope is 1/cost_scale (0.01); a multi-task value credits a lower "
        "next-task cost over later tasks too, so its slope is larger. A GNN is scored on the states it did not learn from: its validation split "
        "where the dataset is its own, the states outside its training set on another one (the states column says "
        "which). "
        "`python -m learning.values.rank --data runs/gnn/<layout>-<variant> --value CKPT [--value CKPT ...]`.",
        *(["", "How much preparedness varies among a file's states at all:", "", *spreads] if spreads else []),
    ]


def everything(layouts=LAYOUTS, checkpoint_paths=(), sha=None) -> dict[str, list[str]]:
    """{section title: lines} of the reference tables."""
    return {
        "Myopic oracle: the two planners": oracle_planners(layouts),
        "Clairvoyant-K oracle: windows": clairvoyant_windows(layouts),
        "Checkpoints": checkpoints(list(checkpoint_paths), sha),
        "Training runs (Appendix A.2)": training_runs(),
        "Target bound (a fix the thesis does not have)": target_bound_runs(),
        "How the values rank states (exact C_AP)": value_ranking(),
        "Minimal example (thesis §5.1)": minimal_example(),
        "Reward calibration (thesis §5.2.4)": calibration(layouts),
        "β selection (Appendix A.1)": beta_selection(layouts),
        "Benchmarks": benchmarks(),
    }

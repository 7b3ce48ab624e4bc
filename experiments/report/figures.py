"""The report's figures (matplotlib, Agg): each function takes plain numbers, writes one PNG, returns its path.

Every function returns None when it has nothing to draw, so the report can say
"not run" instead of embedding an empty plot. Thesis figures, where the thesis
states them, are drawn as open markers beside ours.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

DPI = 110
OURS, THESIS = "tab:blue", "tab:gray"
HORIZON_COLOURS = {"myopic": "tab:orange", "anticipatory": "tab:blue"}


def _save(fig, path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=DPI, bbox_inches="tight", metadata={"Software": None})
    plt.close(fig)
    return path


def greedy_vs_guided(data: dict, thesis: dict, path) -> Path | None:
    """Figure 5.3. data[layout][(horizon, deployment)] = cost per task per seed; thesis[layout][(h, d)] = cost.
    Points: mean over seeds; bars: min–max over seeds; open markers: the thesis."""
    if not any(v for per in data.values() for v in per.values()):
        return None
    layouts = list(data)
    fig, axes = plt.subplots(1, len(layouts), figsize=(4.6 * len(layouts), 3.8), squeeze=False, layout="constrained")
    for ax, layout in zip(axes[0], layouts):
        for k, horizon in enumerate(("myopic", "anticipatory")):
            xs, means, lo, hi, th = [], [], [], [], []
            for x, dep in enumerate(("greedy", "guided")):
                seeds = data[layout].get((horizon, dep)) or []
                xpos = x + (k - 0.5) * 0.12
                if seeds:
                    m = float(np.mean(seeds))
                    xs.append(xpos), means.append(m), lo.append(m - min(seeds)), hi.append(max(seeds) - m)
                t = thesis.get(layout, {}).get((horizon, dep))
                if t is not None:
                    th.append((xpos + 0.05, t))
            c = HORIZON_COLOURS[horizon]
            if xs:
                ax.errorbar(xs, means, yerr=[lo, hi], fmt="o-", color=c, capsize=4, label=f"{horizon} (ours)")
            if th:
                ax.plot(*zip(*th), "s--", mfc="none", color=c, alpha=0.6, label=f"{horizon} (thesis)")
        ax.set_xticks([0, 1], ["greedy", "guided"])
        ax.set_xlim(-0.5, 1.5)
        ax.set_title(layout)
        ax.set_ylabel("cost per task (PDDL units)")
        ax.grid(axis="y", alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(
        "Figure 5.3: greedy vs value-guided deployment (points: seed mean; bars: min–max over seeds)", fontsize=9
    )
    return _save(fig, path)


def improvement_bars(data: dict, path) -> Path | None:
    """Figure 5.4. data[layout] = [(agent label, ours or None, thesis or None)], improvements as fractions."""
    if not any(o is not None for rows in data.values() for _, o, _ in rows):
        return None
    layouts = list(data)
    fig, axes = plt.subplots(
        1, len(layouts), figsize=(4.2 * len(layouts) + 1.8, 4.2), squeeze=False, sharey=True, layout="constrained"
    )
    for ax, layout in zip(axes[0], layouts):
        rows = data[layout]
        y = np.arange(len(rows))
        ours = [o * 100 if o is not None else 0 for _, o, _ in rows]
        th = [t * 100 if t is not None else 0 for _, _, t in rows]
        ax.barh(y - 0.2, ours, 0.4, color=OURS, label="ours")
        ax.barh(y + 0.2, th, 0.4, color=THESIS, alpha=0.6, label="thesis")
        for k, (_, o, _) in enumerate(rows):
            if o is None:
                ax.text(0, k - 0.2, " not run", va="center", fontsize=7, color="tab:red")
        ax.set_yticks(y, [label for label, _, _ in rows], fontsize=8)
        if ax is axes[0][0]:
            ax.invert_yaxis()
        ax.axvline(0, color="black", lw=0.8)
        ax.set_xlabel("improvement over the myopic oracle (%)")
        ax.set_title(layout)
        ax.grid(axis="x", alpha=0.3)
    axes[0][-1].legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.02, 1))
    fig.suptitle("Figure 5.4: cost reduction over the myopic oracle", fontsize=9)
    return _save(fig, path)


def sequence_distributions(data: dict, path) -> Path | None:
    """Figure A.4. data[layout] = [(agent label, [cost per task of each sequence (and seed)])], boxes sorted
    by median."""
    if not any(v for rows in data.values() for _, v in rows):
        return None
    layouts = list(data)
    fig, axes = plt.subplots(len(layouts), 1, figsize=(7.5, 3.6 * len(layouts)), squeeze=False, layout="constrained")
    for ax, layout in zip(axes[:, 0], layouts):
        rows = sorted([r for r in data[layout] if r[1]], key=lambda r: np.median(r[1]))
        ax.boxplot([v for _, v in rows], orientation="horizontal", widths=0.6, showfliers=True)
        for k, (_, v) in enumerate(rows):
            ax.scatter(v, np.full(len(v), k + 1) + np.linspace(-0.15, 0.15, len(v)), s=8, color=OURS, alpha=0.6)
        ax.set_yticks(range(1, len(rows) + 1), [label for label, _ in rows], fontsize=8)
        ax.set_xlabel("mean cost per task of a 50-task sequence")
        ax.set_title(layout)
        ax.grid(axis="x", alpha=0.3)
    fig.suptitle("Figure A.4: per-sequence cost distributions (sorted by median; dots: sequences × seeds)", fontsize=9)
    return _save(fig, path)


def cumulative_cost(data: dict, sequence: int, path) -> Path | None:
    """Figure A.5. data[layout] = [(agent label, [per-task costs of the sequence, one list per seed])]:
    median over seeds and the min–max band."""
    if not any(v for rows in data.values() for _, v in rows):
        return None
    layouts = list(data)
    fig, axes = plt.subplots(len(layouts), 1, figsize=(7.5, 3.4 * len(layouts)), squeeze=False, layout="constrained")
    for ax, layout in zip(axes[:, 0], layouts):
        for label, seeds in data[layout]:
            if not seeds:
                continue
            cum = np.array([np.cumsum(s) for s in seeds], dtype=float)
            x = np.arange(1, cum.shape[1] + 1)
            (line,) = ax.plot(x, np.median(cum, axis=0), label=f"{label} ({len(seeds)} seed{'s' * (len(seeds) > 1)})")
            if len(seeds) > 1:
                ax.fill_between(x, cum.min(axis=0), cum.max(axis=0), color=line.get_color(), alpha=0.2)
        ax.set_xlabel(f"task of sequence {sequence:02d}")
        ax.set_ylabel("cumulative cost")
        ax.set_title(layout)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle(
        f"Figure A.5: cumulative cost over sequence {sequence:02d} (median over seeds, min–max band)", fontsize=9
    )
    return _save(fig, path)


def cost_by_task_type(data: dict, path) -> Path | None:
    """Figure A.6. data[layout] = {agent label: {task type: (mean cost, standard error)}}."""
    if not any(data.values()):
        return None
    layouts = [layout for layout in data if data[layout]]
    fig, axes = plt.subplots(1, len(layouts), figsize=(6 * len(layouts), 4), squeeze=False, layout="constrained")
    for ax, layout in zip(axes[0], layouts):
        agents = data[layout]
        types = sorted({t for per in agents.values() for t in per})
        width = 0.8 / max(1, len(agents))
        for k, (label, per) in enumerate(agents.items()):
            x = np.arange(len(types)) + (k - (len(agents) - 1) / 2) * width
            ax.bar(
                x,
                [per.get(t, (0, 0))[0] for t in types],
                width,
                yerr=[per.get(t, (0, 0))[1] for t in types],
                capsize=2,
                label=label,
            )
        ax.set_xticks(range(len(types)), types, rotation=30, ha="right", fontsize=8)
        ax.set_ylabel("mean cost per task")
        ax.set_title(layout)
        ax.grid(axis="y", alpha=0.3)
        ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.22), ncol=2)
    fig.suptitle("Figure A.6: cost by task type (error bars: standard error of the mean)", fontsize=9)
    return _save(fig, path)


TRAINING_PANELS = (
    ("success_rate", "success (last 100 tasks)"),
    ("task_return", "task return"),
    ("selected_q", "selected Q"),
    ("td_target", "TD target"),
)
SYMLOG_ABOVE = 1e3
"""A panel whose values pass this (a diverged run's Q reaches 1e10) gets a symmetric log axis, linear
within ±SYMLOG_LINEAR, so the healthy runs' curves stay apart."""
SYMLOG_LINEAR = 10.0


def _band(ax, runs: list[list[dict]], key, colour, label) -> float:
    """Median over runs and the min–max band of `key`, on the steps every run logged; returns the largest
    |value| drawn (0 when nothing is)."""
    series = [{r["step"]: r[key] for r in rows if key in r and r.get(key) is not None} for rows in runs]
    series = [s for s in series if s]
    if not series:
        return 0.0
    steps = sorted(set.intersection(*(set(s) for s in series)))
    if not steps:
        return 0.0
    v = np.array([[s[t] for t in steps] for s in series], dtype=float)
    ax.plot(steps, np.nanmedian(v, axis=0), color=colour, label=label)
    if len(series) > 1:
        ax.fill_between(steps, np.nanmin(v, axis=0), np.nanmax(v, axis=0), color=colour, alpha=0.2)
    return float(np.nanmax(np.abs(v)))


def seeds_label(horizon: str, runs: dict) -> str:
    """A legend entry that counts the runs drawn against every run behind the row, naming the seeds drawn:
    'myopic: 3 of 5 seeds (8, 16, 42)'."""
    drawn = [s for s, rows in runs.items() if rows]
    return f"{horizon}: {len(drawn)} of {len(runs)} seed{'s' * (len(runs) != 1)} ({', '.join(map(str, drawn))})"


def training_curves(logs: dict, path) -> Path | None:
    """Figure A.1. logs[layout][horizon] = {seed: metrics rows of its run, [] where no log is here}, every
    finished run of the tables: median and min–max band over the seeds drawn; the legend counts them of all.
    A panel past SYMLOG_ABOVE is drawn on a symmetric log axis (its y label says so)."""
    if not any(rows for per in logs.values() for runs in per.values() for rows in runs.values()):
        return None
    layouts = [layout for layout in logs if any(rows for runs in logs[layout].values() for rows in runs.values())]
    fig, axes = plt.subplots(len(layouts), 4, figsize=(15, 3.2 * len(layouts)), squeeze=False, layout="constrained")
    for row, layout in zip(axes, layouts):
        for ax, (key, title) in zip(row, TRAINING_PANELS):
            top = max(
                [
                    _band(
                        ax,
                        [rows for rows in runs.values() if rows],
                        key,
                        HORIZON_COLOURS.get(horizon, "black"),
                        seeds_label(horizon, runs),
                    )
                    for horizon, runs in logs[layout].items()
                ],
                default=0.0,
            )
            if top > SYMLOG_ABOVE:
                ax.set_yscale("symlog", linthresh=SYMLOG_LINEAR)
                ax.set_ylabel(f"symlog (linear within ±{SYMLOG_LINEAR:g})", fontsize=7)
            ax.set_title(f"{layout}: {title}", fontsize=9)
            ax.set_xlabel("training step")
            ax.grid(alpha=0.3)
        row[0].legend(fontsize=7)
    fig.suptitle(
        "Figure A.1: training diagnostics (median over the seeds drawn, min–max band; legend: seeds drawn "
        f"of the row's runs; Q and TD target on a symlog axis where a run passes {SYMLOG_ABOVE:,.0f})",
        fontsize=9,
    )
    return _save(fig, path)


def refill_share(logs: dict, path, action: str) -> Path | None:
    """Figure A.2. logs[label] = metrics rows of one run: the share of `action` (the domain's [preparation]
    action) among all actions since step 0 (cumulative, as the authors' code plots it; each log row has its
    window's share, each row of an exported curve the cumulative share); None where the domain has no such action."""
    if action is None:
        return None
    curves = {}
    for label, rows in logs.items():
        pts, done, prev = [], 0.0, 0
        for r in rows:
            if r.get("refill_share_cumulative") is not None and r.get("step"):
                pts.append((r["step"], r["refill_share_cumulative"]))
            elif isinstance(r.get("action_share"), dict) and r.get("step"):
                done += r["action_share"].get(action, 0.0) * (r["step"] - prev)
                prev = r["step"]
                pts.append((r["step"], done / r["step"]))
        if pts:
            curves[label] = pts
    if not curves:
        return None
    fig, ax = plt.subplots(figsize=(7, 3.6), layout="constrained")
    for label, pts in curves.items():
        ax.plot(*zip(*pts), label=label)
    ax.set_xlabel("training step")
    ax.set_ylabel(f"share of actions since step 0: {action}")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(f"Figure A.2: share of {action} among all actions so far (cumulative)", fontsize=9)
    return _save(fig, path)


def minimal_example(ours: dict, thesis: dict, path) -> Path | None:
    """Figure 5.1b. ours[horizon] = {q_A, q_B, exact_q_A, exact_q_B, share_B}; thesis[horizon] = {q_A, q_B}."""
    horizons = [h for h in ("myopic", "anticipatory") if h in ours]
    if not horizons:
        return None
    fig, ax = plt.subplots(figsize=(6, 3.8), layout="constrained")
    x = np.arange(len(horizons))
    for k, (place, colour) in enumerate((("A", "tab:olive"), ("B", "tab:purple"))):
        xs = x + (k - 0.5) * 0.36
        ax.bar(xs, [ours[h][f"q_{place}"] for h in horizons], 0.34, color=colour, label=f"learned Q, place on {place}")
        ax.scatter(
            xs,
            [ours[h].get(f"exact_q_{place}", np.nan) for h in horizons],
            marker="_",
            s=400,
            color="black",
            zorder=3,
            label="exact (BFS)" if k == 0 else None,
        )
        ax.scatter(
            xs,
            [thesis.get(h, {}).get(f"q_{place}", np.nan) for h in horizons],
            marker="o",
            facecolors="none",
            edgecolors="tab:gray",
            s=60,
            zorder=3,
            label="thesis" if k == 0 else None,
        )
    for i, h in enumerate(horizons):
        gap, share = ours[h]["q_B"] - ours[h]["q_A"], ours[h].get("share_B")
        ax.text(
            i,
            max(ours[h]["q_A"], ours[h]["q_B"]) + 0.9,
            f"gap {gap:+.3f}" + (f", {100 * share:.1f}% on B" if share is not None else ""),
            ha="center",
            fontsize=8,
        )
    ax.set_xticks(x, horizons)
    ax.set_ylabel("Q(s, clear(c), place(apple, ·))")
    ax.set_ylim(0, max(max(ours[h]["q_A"], ours[h]["q_B"]) for h in horizons) * 1.25)
    ax.legend(fontsize=7, loc="upper left")
    ax.set_title("Figure 5.1b: learned Q of the two task-1 placements (minimal example)", fontsize=9)
    return _save(fig, path)

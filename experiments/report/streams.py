"""Beyond the thesis: the task streams a domain declares ([streams.<name>], `planning.world.streams`), as a
section of the report: what each distribution estimator (`planning.world.estimators`) buys on each stream.

Per layout and stream (the i.i.d. one and every declared one), the rows:
- the myopic oracle (our optimal A*, whose costs equal Fast Downward's on every i.i.d. task, in seconds
  instead of an hour per stream) and the clairvoyant oracle (K = 2 and 3) on the stream's canonical
  sequences: the reference every improvement is measured against, and the floor;
- the thesis's agent: the anticipatory value trained on the i.i.d. stream and deployed with the layout's P
  (on another stream, the misspecified assumption); on the i.i.d. stream it is Table 5.2's row;
- the same i.i.d.-trained value deployed with each estimator below: the search's terminal score conditioned
  on the task just done (or learned online) with the value as trained, what the estimator buys without
  retraining;
- agents trained on the stream with an estimator and deployed with the same one (`rl-guided --estimator`): on
  a Markov stream `markov` (P(τ′ | τ) known) and `markov-empirical` (transition counts learned online); on a
  drifting stream `empirical` (stationary counts) and `empirical` with forgetting (`FORGET` per task, a
  running average weighted towards recent tasks); on the i.i.d. stream `empirical` (P learned from nothing).

The questions each table answers are the issue's: on a Markov stream, does conditioning V_AP on the task
just done beat the i.i.d. assumption (Wilcoxon over sequences against the thesis's agent), and what share of
the clairvoyant K = 2 saving does it recover; on the i.i.d. stream, how close does the empirical estimate come
to the known P; on a drifting stream, does forgetting win after the change (the cost per task over the
position in the sequence, `figure`, the mean over the tasks from the last phase's start on, and the tests of
each forgetting row against its stationary twin on those tasks, `from_position`).
Everything a row lacks is listed with the commands that train and evaluate it.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from experiments.report.data import RowResult, improvement, load_rows
from experiments.report.specs import LEAST_SEEDS, Row, Run, results_name, rl_seeds, rl_suffix
from experiments.report.tables import num, pct, pm, share, statistics, table

FORGET = 0.95
"""The forgetting estimator's decay per task: counts weigh about the last 1 / (1 − 0.95) = 20 tasks, well inside
the restaurant's 25-task phases, so the estimate can settle after a change within a sequence."""
ESTIMATORS = {
    "iid": (("empirical", 1.0),),
    "markov": (("markov", 1.0), ("markov-empirical", 1.0)),
    "drift": (("empirical", 1.0), ("empirical", FORGET)),
}
"""The estimators tried on each kind of stream (name, forgetting factor)."""


def estimator_label(name: str, forget: float) -> str:
    return name + ("" if forget == 1.0 else f"-forget{forget:g}")


def stream_names(model) -> list[tuple[str, str]]:
    """(name, kind) of the layout's streams: the i.i.d. one first, then the declared ones."""
    from planning.world.streams import streams

    return [(name, s.kind) for name, s in streams(model).items()]


def _suffix(stream: str) -> str:
    return "" if stream == "iid" else f"-stream-{stream}"


@dataclass(frozen=True)
class Names:
    """How one layout of a domain names the section's files and commands: what `experiments.evaluate`,
    `learning.dqn` and `learning.export` name them by default (`specs.results_name`; the restaurant's names carry
    no domain and its commands no --domain), and the seeds of the thesis's agent there."""

    folder: str  # the domain folder
    domain: str  # its PDDL name
    layout: str
    mark: str  # the task encoding's mark, where not the thesis's (`specs.rl_suffix`)
    iid_seeds: tuple

    @property
    def flag(self) -> tuple:
        """--domain FOLDER, but for the domain whose files carry no prefix (the default one)."""
        from planning.world.results import file_prefix

        return ("--domain", self.folder) if file_prefix(self.domain) else ()

    def out(self, run: str) -> str:
        return results_name(self.domain, run, self.layout)

    def trained(self, s, tail: str = "", train_flags: str = "") -> tuple[str, str]:
        """(checkpoint, command that trains and exports it) of the anticipatory value of seed `s` whose run name
        ends in `tail` (`learning.q.training.bound_suffix` after the task encoding's mark)."""
        from planning.world.results import file_prefix

        ckpt = f"checkpoints/{file_prefix(self.domain)}rl-anticipatory-{self.layout}-seed{s}{self.mark}{tail}.pt"
        train = (
            f"python -m learning.dqn{''.join(' ' + x for x in self.flag)} --layout {self.layout} --horizon anticipatory "
            f"--seed {s}{train_flags} && python -m learning.export "
            f"runs/dqn/{self.domain}-{self.layout}-anticipatory-seed{s}{self.mark}{tail}"
        )
        return ckpt, train


def names(ctx, layout: str, iid_seeds=None) -> Names:
    """The layout's `Names`; the thesis's agent's seeds are `iid_seeds(layout)` where given, else those trained
    (`specs.rl_seeds`) and at least `LEAST_SEEDS`."""
    model = ctx.model(layout)
    mark = rl_suffix(model)
    seeds = (
        iid_seeds(layout) if iid_seeds else sorted({*LEAST_SEEDS, *rl_seeds(model.name, layout, "anticipatory", mark)})
    )
    return Names(str(ctx.domain), model.name, layout, mark, tuple(seeds))


def _flags(name: str, forget: float) -> str:
    return f"--estimator {name}" + ("" if forget == 1.0 else f" --estimator-forget {forget:g}")


def _est_run(n: Names, stream: str, name: str, forget: float, s) -> Run:
    """The anticipatory agent trained on the stream with an estimator, deployed with the same one."""
    tag = f"{_suffix(stream)}-est-{estimator_label(name, forget)}"
    flags = _flags(name, forget)
    ckpt, train = n.trained(s, tag, ("" if stream == "iid" else f" --stream {stream}") + f" {flags}")
    options = (*n.flag, "--checkpoint", ckpt, *flags.split(), *(() if stream == "iid" else ("--stream", stream)))
    out = n.out(f"rl-guided-anticipatory-{n.layout}-seed{s}{n.mark}{tag}")
    return Run("rl-guided", n.layout, options, out, s, ckpt, train)


def _iid_run(n: Names, stream: str, s) -> Run:
    """The thesis's agent (i.i.d.-trained value, the layout's P) played on the stream's sequences."""
    ckpt, train = n.trained(s)
    options = (*n.flag, "--checkpoint", ckpt, *(() if stream == "iid" else ("--stream", stream)))
    out = n.out(f"rl-guided-anticipatory-{n.layout}-seed{s}{n.mark}{_suffix(stream)}")
    return Run("rl-guided", n.layout, options, out, s, ckpt, train)


def _deploy_run(n: Names, stream: str, name: str, forget: float, s) -> Run:
    """The thesis's agent (the i.i.d.-trained value) deployed with an estimator: the search's terminal score
    conditioned or learned, the value as trained (what the estimator buys without retraining)."""
    ckpt, train = n.trained(s)
    options = (
        *n.flag,
        "--checkpoint",
        ckpt,
        *_flags(name, forget).split(),
        *(() if stream == "iid" else ("--stream", stream)),
    )
    label = estimator_label(name, forget)
    out = n.out(f"rl-guided-anticipatory-{n.layout}-seed{s}{n.mark}{_suffix(stream)}-deploy-{label}")
    return Run("rl-guided", n.layout, options, out, s, ckpt, train)


def rows(n: Names, stream: str, kind: str) -> list[Row]:
    """The section's rows for one layout and stream (see the module)."""
    from oracles.clairvoyant import run_name  # the oracle's own file name; a heavy import, so here

    layout, extra = n.layout, (() if stream == "iid" else ("--stream", stream))
    out = [
        Row(
            "myopic-oracle",
            "Myopic oracle (optimal, internal A*)",
            layout,
            (
                Run(
                    "myopic-oracle",
                    layout,
                    (*n.flag, "--planner", "internal", *extra),
                    n.out(f"myopic-oracle-internal-{layout}{_suffix(stream)}"),
                ),
            ),
        ),
        *(
            Row(
                f"clairvoyant-{k}",
                f"Clairvoyant oracle (K = {k})",
                layout,
                (
                    Run(
                        "clairvoyant",
                        layout,
                        (*n.flag, "--K", str(k), "--time-limit", "60", *extra),
                        n.out(f"{run_name(k)}-{layout}{_suffix(stream)}"),
                    ),
                ),
            )
            for k in (2, 3)
        ),
        Row(
            "iid-agent",
            "Anticipatory RL (guided), i.i.d. P (the thesis's)",
            layout,
            tuple(_iid_run(n, stream, s) for s in n.iid_seeds),
            seeded=True,
            template=_iid_run(n, stream, "$N"),
        ),
    ]
    kinds = (
        ("dep", "i.i.d.-trained, deployed with", _deploy_run),
        ("est", "trained and deployed with", _est_run),
    )
    for prefix, how, run in kinds:
        for name, forget in ESTIMATORS[kind]:
            label = estimator_label(name, forget)
            out.append(
                Row(
                    f"{prefix}-{label}",
                    f"Anticipatory RL (guided), {how} {label}",
                    layout,
                    tuple(run(n, stream, name, forget, s) for s in LEAST_SEEDS),
                    seeded=True,
                    template=run(n, stream, name, forget, "$N"),
                )
            )
    return out


def declared(ctx, layouts) -> bool:
    """Whether any of the layouts has a stream besides the i.i.d. one (the section's reason to be)."""
    return any(kind != "iid" for layout in layouts for _, kind in stream_names(ctx.model(layout)))


def load_specs(ctx, layouts, iid_seeds=None) -> list[list[Row]]:
    """The rows of every layout and stream (what `experiments.reproduce --streams` plays; `iid_seeds` as for
    `names`)."""
    return [
        rows(names(ctx, layout, iid_seeds), s, kind)
        for layout in layouts
        for s, kind in stream_names(ctx.model(layout))
    ]


def load(ctx, layouts, iid_seeds=None) -> dict:
    """{(layout, stream, kind): {row key: RowResult}} for every layout and stream."""
    return {
        (layout, stream, kind): load_rows(rows(names(ctx, layout, iid_seeds), stream, kind), ctx)
        for layout in layouts
        for stream, kind in stream_names(ctx.model(layout))
    }


def _cost(rr: RowResult) -> str:
    f = rr.figures()
    if f is None:
        return "not run ([commands](#stream-runs-not-yet-made))"
    return pm(f["cost"], f["cost_std"]) if rr.row.seeded else num(f["cost"])


def stream_table(rows: dict) -> list[str]:
    """One layout and stream: cost per task, improvement over the stream's myopic oracle, share of the
    clairvoyant K = 2 saving, seeds and files."""
    ref, k2 = rows["myopic-oracle"], rows["clairvoyant-2"]
    body = []
    for key, rr in rows.items():
        f, gain = rr.figures(), improvement(rr, ref)
        c_myo, c_k2 = ref.figures(), k2.figures()
        saved = (
            share(c_myo["cost"], f["cost"], c_k2["cost"])
            if f is not None and c_myo is not None and c_k2 is not None and c_myo["sequences"] == f["sequences"]
            else None
        )
        body.append(
            [
                rr.row.label,
                _cost(rr),
                "(reference)" if key == "myopic-oracle" else pct(gain) if gain is not None else "—",
                "—" if saved is None or key == "myopic-oracle" else f"{saved:.0%}",
                f"{len(rr.used)} of {len(rr.row.runs)}" if rr.row.seeded else "—",
                "<br>".join(f"`{x.run.out}`" for x in rr.loaded if x.used) or "—",
            ]
        )
    return table(["method", "cost/task", "improvement", "share of K = 2 saving", "seeds", "results files"], body)


def by_position(rr: RowResult) -> np.ndarray | None:
    """(50,) cost per task at each position of a sequence, mean over the row's seeds and sequences."""
    costs: dict = {}
    for d in rr.used:
        for r in d.get("per_task", []):
            costs.setdefault(r["index"], []).append(r["cost"])
    if not costs:
        return None
    return np.array([np.mean(costs[i]) for i in sorted(costs)])


def after_change(rows: dict, change: int) -> list[str]:
    """The mean cost per task before position `change` and from it on (the last phase), per row that has one."""
    body, last = [], 0
    for rr in rows.values():
        pos = by_position(rr)
        if pos is not None and len(pos) > change:
            body.append([rr.row.label, num(float(pos[:change].mean())), num(float(pos[change:].mean()))])
            last = max(last, len(pos) - 1)
    return table(["method", f"tasks 0–{change - 1}", f"tasks {change}–{last}"], body) if body else []


def from_position(rr: RowResult, start: int) -> RowResult:
    """The row with each results file cut to the tasks at positions `start` on: per sequence, their cost and
    count (what `experiments.stats` reads), so that the §5.4.3 tests compare the rows after a change."""
    from dataclasses import replace

    def cut(d: dict | None) -> dict | None:
        if d is None:
            return None
        seqs: dict = {}
        for r in d.get("per_task", []):
            if r["index"] >= start:
                c = seqs.setdefault(r["sequence"], {"id": r["sequence"], "cost": 0.0, "tasks": 0})
                c["cost"] += r["cost"]
                c["tasks"] += 1
        return {**d, "per_sequence": [seqs[i] for i in sorted(seqs)]}

    return RowResult(rr.row, [replace(x, data=cut(x.data)) for x in rr.loaded])


def forgetting_pairs(rows: dict) -> list[tuple[str, str]]:
    """(forgetting row, its stationary twin) for each estimator row that forgets: the drifting stream's question."""
    return [
        (key, twin)
        for key in rows
        if key.startswith(("est-", "dep-")) and "-forget" in key
        for twin in [key.split("-forget")[0]]
        if twin in rows
    ]


def figure(ctx, results: dict, folder: Path, tracked: dict) -> dict:
    """{(layout, stream): PNG or None}: the cost per task over the position in the sequence, every drifting
    stream's rows, above how far each estimate is from the stream there (`tracked[(layout, stream)]`, from
    `estimates`, over task instances; a vertical line at each phase's start)."""
    from experiments.report.figures import _save, plt
    from planning.world.results import file_prefix

    out = {}
    for (layout, stream, kind), rows in results.items():
        if kind != "drift":
            continue
        lines = [(rr.row.label, by_position(rr)) for rr in rows.values()]
        lines = [(label, y) for label, y in lines if y is not None]
        path = folder / f"fig-stream-{file_prefix(ctx.model(layout).name)}{layout}-{stream}.png"
        if not lines:
            out[(layout, stream)] = None
            continue
        fig, (ax, est) = plt.subplots(2, 1, figsize=(7.5, 6.0), sharex=True, height_ratios=(3, 2), layout="constrained")
        for label, y in lines:
            ax.plot(np.arange(len(y)), y, label=label, lw=1.2)
        for label, d in (tracked[(layout, stream)] or (0, {}))[1].items():
            est.plot(np.arange(1, len(d["instances"]) + 1), d["instances"], label=label, lw=1.2)
        for a in (ax, est):
            for start in phase_starts(ctx, layout, stream):
                a.axvline(start, color="k", lw=0.8, ls="--")
            a.grid(alpha=0.3)
            a.legend(fontsize=7)
        ax.set_ylabel("cost per task (mean over sequences and seeds)")
        ax.set_title(f"{layout}, stream {stream}")
        est.set_ylabel("estimate's distance to the\nstream (total variation)")
        est.set_xlabel("position of the task in its sequence")
        out[(layout, stream)] = _save(fig, path)
    return out


def phase_starts(ctx, layout: str, stream: str) -> list[int]:
    """The positions where a drifting stream's phases begin (after the first; none for another stream)."""
    from planning.world.streams import stream as stream_of

    return [f for f, _ in stream_of(ctx.model(layout), stream).phases[1:]]


def estimates(ctx, layout: str, stream: str, kind: str) -> tuple[int, dict] | None:
    """(sequences, {estimate's label: `planning.world.estimators.tracking` of it}) on the stream's canonical
    sequences: the known P and each estimator tried on this kind of stream, fed as the guided agent feeds them
    (None where the sequences are not written yet)."""
    from planning.world import sequences
    from planning.world.estimators import build, tracking
    from planning.world.streams import stream as stream_of

    model = ctx.model(layout)
    s = stream_of(model, stream)
    name = None if stream == "iid" else stream
    if not any(sequences.sequence_dir(model, name).glob("seq-*.json")):
        return None
    tasks = [q.tasks for q in sequences.load(model, stream_name=name)]
    out = {}
    for name, forget in [("known", 1.0), *ESTIMATORS[kind]]:
        label = "known P (the thesis's)" if name == "known" else estimator_label(name, forget)
        out[label] = tracking(lambda name=name, forget=forget: build(name, model, s, forget=forget), s, tasks)
    return len(tasks), out


def tracking_table(ctx, layout: str, stream: str, tracked: tuple[int, dict] | None) -> list[str]:
    """How far each estimate is from the stream's own next-task distribution on its canonical sequences
    (`tracked`, from `estimates`: a fresh estimate per sequence), at a few positions: around the last phase's
    start on a drifting stream, along the sequence otherwise; the command that writes the sequences where
    there are none."""
    if tracked is None:
        from planning.world.sequences import sequence_dir

        where = sequence_dir(ctx.model(layout), None if stream == "iid" else stream)
        return [
            f"No canonical sequences of this stream in `{where}` (every row needs them): `python -m "
            f"planning.world.sequences --domain {ctx.domain} --layout {layout} --stream {stream}` writes them.",
            "",
        ]
    n, curves = tracked
    starts = phase_starts(ctx, layout, stream)
    change, last = (starts[-1] if starts else None), len(next(iter(curves.values()))["types"])
    positions = (change - 1, change, change + 5, change + 10, last) if change else (1, 5, 10, last // 2, last)
    positions = [p for p in positions if 1 <= p <= last]
    body = []
    for label, d in curves.items():
        cells = [f"{d['types'][p - 1]:.2f} / {d['instances'][p - 1]:.2f}" for p in positions]
        body.append([label, *cells, f"{d['types'].mean():.2f} / {d['instances'].mean():.2f}"])
    return [
        "How far each estimate is from the stream's own next-task distribution, as the deployed agent feeds it "
        f"(a fresh estimate per sequence; mean over the {n} canonical sequences): the total-variation "
        "distance over task types / over task instances (what V_AP sums over), before task p is drawn "
        "(`planning.world.estimators.tracking`)"
        + (f"; the last phase starts at task {change}" if change else "")
        + ". A learned estimate can help the search only where it is nearer the stream than the known P is.",
        "",
        *table(["estimate", *(f"p = {p}" for p in positions), f"mean, p = 1–{last}"], body),
        "",
    ]


def sequence_length(tracked: tuple[int, dict] | None) -> int:
    """The length of the canonical sequences `estimates` tracked (theirs where written, else the default)."""
    from planning.world.sequences import LENGTH

    return LENGTH if tracked is None else len(next(iter(tracked[1].values()))["types"]) + 1


def missing(results: dict) -> list[str]:
    """The runs the section lacks, with the commands that train and evaluate them."""
    from experiments.report.tables import missing_runs

    named = {f"{layout}, stream {stream}": rows for (layout, stream, _), rows in results.items()}
    return missing_runs(named)


def _dataset_command(c: dict, d: dict) -> str:
    """ ", the states from `python -m learning.gnn_dataset ...`" for a ranking whose dataset recorded its settings."""
    cfg = c.get("dataset") or {}
    if not cfg.get("n_states"):
        return ""
    extra = f" --augmented --n-prepared {cfg['n_prepared']}" if cfg.get("augmented") else ""
    extra += f" --seed {cfg['seed']}" if cfg.get("seed") else ""
    return (
        f"; the states from `python -m learning.gnn_dataset --layout {cfg['layout']} --n-states {cfg['n_states']}"
        f"{extra} --out {d['data']}`"
    )


def ranking(domain: str, layout: str, stream: str) -> list[str]:
    """How much conditioning on the stream can reorder states, and how the values rank by the conditional
    C_AP with and without it (`results/value-rank-*.json` made with `learning.values.rank --stream`)."""
    from experiments.report.data import read_finished
    from planning.world.results import file_prefix

    lines, prefix = [], file_prefix(domain)
    for path in sorted(Path("results").glob(f"{prefix}value-rank-*.json")):
        d = read_finished(path) or {}
        c = d.get("conditional") or {}
        if d.get("layout") != layout or c.get("stream") != stream:
            continue
        values = [
            Path(e["value"]).stem.replace(f"{prefix}rl-anticipatory-{layout}-", "") for e in c["contexts"][0]["values"]
        ]
        body = []
        for row in c["contexts"]:
            likeliest = max(row["next_types"], key=row["next_types"].get)
            cells = [
                f"{num(e['unconditioned'].get('spearman'), 3)} → "
                + ("—" if e["conditioned"] is None else num(e["conditioned"].get("spearman"), 3))
                for e in row["values"]
            ]
            body.append(
                [
                    row["context"],
                    f"{likeliest} {row['next_types'][likeliest]:.2f}",
                    num(row["exact_under_p"].get("spearman"), 3),
                    *cells,
                ]
            )
        lines += [
            f"How the values rank the {c['states']} states of `{d['data']}` by the exact C_AP under each context's "
            f"next-task distribution (`{path.name}`; Spearman): the exact C_AP under the layout's P, then each "
            "value's V_AP with P → with the context's distribution.",
            "",
            *table(["context", "likeliest next type", "exact C_AP under P", *(f"`{v}`" for v in values)], body),
            "",
            "Conditioning helps a search only as far as it reorders the states it compares: the exact column says "
            "how much it reorders these states at all (1: not at all), however good the value; a value gains from "
            "being conditioned where its second figure exceeds its first (`python -m "
            f"learning.values.rank --data {d['data']} --value CKPT ... --stream {stream}`{_dataset_command(c, d)}).",
            "",
        ]
    return lines


def _tests(results: dict, pairs: list) -> list[str]:
    """The §5.4.3 tests of the pairs, their missing runs linked to this section's list."""
    tests = statistics(results, pairs, thesis=False, same_seeds=True)
    return [line.replace("(#runs-not-yet-made)", "(#stream-runs-not-yet-made)") for line in tests]


def section(ctx, results: dict, folder: Path) -> list[str]:
    """The report's section on task streams (markdown lines) from `load`'s rows, its figures drawn into `folder`."""
    tracked = {(layout, stream): estimates(ctx, layout, stream, kind) for layout, stream, kind in results}
    drawn = figure(ctx, results, folder, tracked)
    lines = [
        "Beyond the thesis (its limitations L1 and L4): the task distribution learned online and conditioned on "
        "the task just done. Each table is one layout and stream, on that stream's canonical sequences; the "
        "improvement and the share of the clairvoyant K = 2 saving are against that stream's myopic oracle. "
        "The thesis's agent is trained on the i.i.d. stream and weighs V_AP by the layout's P; the estimator "
        "rows are trained on the stream with their estimator and deployed with it (a fresh estimate per "
        "sequence, fed every task posed; `experiments.report.streams`). The tests compare each estimator row "
        "with the thesis's agent as §5.4.3 does (and each forgetting row with its stationary twin), and again on "
        "the seeds both rows have where their seed sets "
        f"differ (the thesis's agent can have more seeds than an estimator row's {len(LEAST_SEEDS)}: a difference of "
        "seeds is not one of estimators).",
        "",
    ]
    for (layout, stream, kind), rows in results.items():
        lines += [f"### {layout}, stream {stream} ({kind})", "", *stream_table(rows), ""]
        pairs = [(k, "iid-agent") for k in rows if k.startswith(("est-", "dep-"))] + forgetting_pairs(rows)
        lines += [*_tests({f"{layout}, {stream}": rows}, pairs), ""]
        lines += ranking(ctx.model(layout).name, layout, stream)
        lines += tracking_table(ctx, layout, stream, tracked[(layout, stream)])
        if kind == "drift":
            starts = phase_starts(ctx, layout, stream)
            if starts:
                change, last = starts[-1], sequence_length(tracked[(layout, stream)]) - 1
                cut = {key: from_position(rr, change) for key, rr in rows.items()}
                lines += [*after_change(rows, change), ""]
                lines += [
                    f"The same tests on the tasks from the last phase's start on (position {change} on): does "
                    "forgetting win after the change?",
                    "",
                    *_tests({f"{layout}, {stream}, tasks {change}–{last}": cut}, forgetting_pairs(rows)),
                    "",
                ]
            path = drawn.get((layout, stream))
            lines += [
                f"![cost per task over the sequence, {layout}, {stream}](figures/{path.name})"
                if path is not None
                else f"**Figure, {layout}, stream {stream}**: not run (needs the rows' per-task results).",
                "",
            ]
    lines += ["### Stream runs not yet made", "", *missing(results), ""]
    return lines

"""The reproduction report: its statistics against hand computations, which results files it uses and flags,
running what is missing (tiny case), the figures, and the report from the committed results."""

import itertools
import json
import math
import time
from pathlib import Path

import pytest
from scipy import stats as sps

from experiments import stats
from experiments.report import figures as figs
from experiments.report.data import Context, load_run
from experiments.report.specs import RL_SEEDS, Row, Run
from experiments.report.thesis import report
from experiments.reproduce import needs_run, run_missing
from planning.world.sequences import Sequence

ROOT = Path(__file__).resolve().parents[2]


def results_set(per_seed: list[list[float]], tasks: int = 50) -> list[dict]:
    """Results JSONs (one per seed) whose sequence i costs per_seed[seed][i] per task."""
    return [
        {
            "per_sequence": [
                {"id": i, "cost": c * tasks, "tasks": tasks, "successes": tasks, "actions": 7 * tasks}
                for i, c in enumerate(costs)
            ]
        }
        for costs in per_seed
    ]


# ---- statistics -----------------------------------------------------------------------------
def test_wilcoxon_matches_the_hand_enumeration():
    """Six paired sequences, A cheaper on five: differences −10, −20, −30, +40, −50, −60 (A averaged over two
    seeds). Ranks 1..6, W+ = 4; under H0 each sign is a coin: P(W+ ≤ 4) counts the rank subsets summing to
    ≤ 4: {}, {1}, {2}, {3}, {4}, {1,2}, {1,3} = 7 of 64, so the two-sided p is 14/64."""
    b = [1000, 1100, 1200, 1300, 1400, 1500]
    diffs = [-10, -20, -30, 40, -50, -60]
    a = results_set([[x + d - 5 for x, d in zip(b, diffs)], [x + d + 5 for x, d in zip(b, diffs)]])
    res = stats.wilcoxon_paired(stats.sequence_costs(a), stats.sequence_costs(results_set([b])))
    assert (res["n"], res["a_cheaper"], res["statistic"]) == (6, 5, 4.0)
    assert res["p"] == pytest.approx(14 / 64)
    ranks = range(1, 7)  # the same p by enumerating all 2^6 sign assignments
    w_plus = [sum(r for r, s in zip(ranks, signs) if s) for signs in itertools.product((0, 1), repeat=6)]
    assert res["p"] == pytest.approx(sum(min(w, 21 - w) <= 4 for w in w_plus) / 64)


def test_wilcoxon_one_way_reaches_the_thesis_minima():
    """Every pair one way: p = 2/2^n, the thesis's 0.002 at n = 10 and 0.0156 at n = 7."""
    b = results_set([[1300 + 10 * i for i in range(10)]])
    a = results_set([[1000 + 7 * i for i in range(10)]])
    all_ten = stats.compare(a, b)["wilcoxon"]
    held_out = stats.compare(a, b, ids=[0, 2, 4, 5, 7, 8, 9])["wilcoxon"]
    assert (all_ten["n"], all_ten["a_cheaper"], all_ten["p"]) == (10, 10, pytest.approx(2 / 1024))
    assert (held_out["n"], held_out["p"]) == (7, pytest.approx(2 / 128))


def test_welch_matches_the_hand_computation():
    """Seed costs A = 10, 12, 14 (mean 12, variance 4), B = 20, 21 (mean 20.5, variance 0.5):
    se = √(4/3 + 0.5/2), t = 8.5 / se, Welch–Satterthwaite df, reduction 8.5 / 20.5 and its interval
    (8.5 ± q se) / 20.5 with q the 0.975 quantile of t(df)."""
    a = results_set([[10, 10], [12, 12], [14, 14]])
    b = results_set([[20, 20], [21, 21]])
    res = stats.compare(a, b)["welch"]
    se = math.sqrt(4 / 3 + 0.5 / 2)
    df = (4 / 3 + 0.25) ** 2 / ((4 / 3) ** 2 / 2 + 0.25**2 / 1)
    assert res["t"] == pytest.approx(8.5 / se) and res["t"] == pytest.approx(6.7551, abs=1e-4)
    assert res["df"] == pytest.approx(df) and df == pytest.approx(2.6350, abs=1e-4)
    assert res["reduction"] == pytest.approx(8.5 / 20.5)
    q = sps.t.ppf(0.975, df)
    assert res["ci"] == pytest.approx(((8.5 - q * se) / 20.5, (8.5 + q * se) / 20.5))
    assert res["p"] == pytest.approx(sps.ttest_ind([10, 12, 14], [20, 21], equal_var=False).pvalue)


def test_welch_from_the_thesis_table_gives_its_interval():
    """Table 5.2's 978 ± 127 (5 seeds) against 1,308 ± 1 (4 seeds): t(4) ≈ 5.8, p ≈ .004, 13.1%–37.3%."""
    res = stats.welch_from_stats(978, 127, 5, 1308, 1, 4)
    assert res["t"] == pytest.approx(5.78, abs=0.05) and res["df"] == pytest.approx(4.0, abs=0.01)
    assert res["p"] == pytest.approx(0.004, abs=0.001)
    assert res["ci"] == pytest.approx((0.131, 0.373), abs=0.002)
    assert res["reduction"] == pytest.approx(0.252, abs=0.001)


def test_one_seed_per_side_is_a_reason_not_a_number():
    res = stats.compare(results_set([[1, 2]]), results_set([[3, 4]]))
    assert "t" not in res["welch"] and "at least 2" in res["welch"]["reason"]
    assert res["welch"]["reduction"] == pytest.approx(1 - 1.5 / 3.5)


def test_rows_of_different_seeds_are_tested_again_on_the_seeds_they_share():
    """A row of seeds 0, 4 against one of seeds 0, 4, 16: the usual tests over all their seeds, then the same
    tests on seeds 0 and 4 alone, where B's lucky seed 16 no longer makes A look worse."""
    from experiments.report.data import Loaded, RowResult
    from experiments.report.tables import shared_seeds, statistics

    def row(key, seeds, per_seed):
        runs = [Run("rl-guided", "two-room", out=f"{key}-{n}.json", seed=n) for n in seeds]
        loaded = [Loaded(r, "ok", data) for r, data in zip(runs, results_set(per_seed))]
        return RowResult(Row(key, key.upper(), "two-room", tuple(runs), seeded=True), loaded)

    a = row("a", [0, 4], [[101 + i for i in range(10)], [201 + i for i in range(10)]])
    b = row("b", [0, 4, 16], [[100 + i for i in range(10)], [200 + i for i in range(10)], [0 + i for i in range(10)]])
    seeds, used_a, used_b = shared_seeds(a, b)
    assert seeds == [0, 4] and used_a == a.used and used_b == b.used[:2]
    assert shared_seeds(a, a) is None  # the same seeds: nothing to add
    lines = statistics({"two-room": {"a": a, "b": b}}, [("a", "b")], thesis=False, same_seeds=True)
    rows = [line for line in lines if line.startswith("| two-room")]
    assert [r.split(" | ")[2] for r in rows] == ["all ten", "held-out seven", "all ten, seeds 0, 4 only"]
    # seed means: A 105.5 and 205.5; B 104.5, 204.5 and 4.5. Over all seeds A looks 48.8% dearer (155.5 against
    # 104.5); on seeds 0 and 4 alone it is dearer by one per sequence: 1 - 155.5 / 154.5 = -0.6%
    assert "0 of 10" in rows[2] and "2 / 2" in rows[2] and "2 / 3" in rows[0]
    assert "−0.6%" in rows[2] and "−48.8%" in rows[0]
    assert "seeds 0, 4 only" not in "\n".join(statistics({"two-room": {"a": a, "b": b}}, [("a", "b")], thesis=False))


# ---- which files a row uses -----------------------------------------------------------------
@pytest.fixture
def tiny(two_room, tmp_path, monkeypatch):
    """Three-task canonical sequences, a context holding the compiled layout, and a `random` run."""
    import planning.world.sequences as sequences

    real_load = sequences.load
    monkeypatch.setattr(
        sequences,
        "load",
        lambda model, ids, stream=None: [Sequence(i, 100 + i, s.tasks[:3]) for i, s in zip(ids, real_load(model, ids))],
    )
    monkeypatch.chdir(tmp_path)
    ctx = Context(str(ROOT / "domains" / "restaurant"))
    ctx._models["two-room"] = two_room
    run = Run("random", "two-room", ("--seed", "1"), str(tmp_path / "random-seed1-two-room.json"))
    return ctx, run, Row("random", "Random", "two-room", (run,))


def test_run_missing_writes_provenance_and_resumes(tiny):
    """The non-report path on a tiny case: the run is played through the registry and the runner, its file
    names the run's command, and a second pass finds nothing to do."""
    ctx, run, row = tiny
    assert load_run(run, ctx).status == "not run"
    assert run_missing([row], ctx, ids=[0, 1], progress=False, via="python -m experiments.reproduce") == [run.out]
    data = json.loads(Path(run.out).read_text())
    prov = data["provenance"]
    assert prov["command"] == run.command and prov["via"] == "python -m experiments.reproduce"
    assert prov["played_in_this_process"] == [0, 1] and prov["date_utc"].endswith("Z")
    assert {"commit", "machine", "uncommitted_code"} <= set(prov)
    loaded = load_run(run, ctx)
    assert loaded.used and loaded.accounting.startswith(("fallback", "no failed"))
    assert not needs_run(loaded, [0, 1]) and needs_run(loaded, [0, 1, 2])
    assert run_missing([row], ctx, ids=[0, 1], progress=False) == []


def test_a_row_flags_or_refuses_what_it_does_not_expect(tiny):
    ctx, run, row = tiny
    run_missing([row], ctx, ids=[0, 1], progress=False)
    data = json.loads(Path(run.out).read_text())
    failed = [r for r in data["per_task"] if not r["success"]]
    assert failed, "the random policy is expected to fail one of six tasks"
    legacy = json.loads(json.dumps(data))  # a file from before the fallback was executed
    for r in legacy["per_task"]:
        r.pop("completed_by", None)
        r.pop("completion_plan", None)
    legacy.pop("provenance")
    legacy.pop("failure_protocol")
    Path(run.out).write_text(json.dumps(legacy))
    loaded = load_run(run, ctx)
    assert not loaded.used and "failure protocol 'charged" in loaded.note
    assert not needs_run(loaded, [0, 1])  # made otherwise: replaced only by its command with --force
    Path(run.out).write_text(json.dumps({**data, "config": {"seed": 2}}))
    other = load_run(run, ctx)
    assert other.status == "not used" and "seed 2" in other.note
    Path(f"{run.out}.partial.json").write_text("{}")
    assert load_run(run, ctx).status == "in progress"
    parted = Run("random", "two-room", ("--seed", "3"), str(Path(run.out).with_name("parted.json")))
    Path(f"{parted.out}.parts").mkdir()
    Path(f"{parted.out}.parts/seq-04.json").write_text("{}")
    loaded = load_run(parted, ctx)
    assert loaded.status == "in progress" and "sequences 04 are in" in loaded.note
    assert load_run(Run("no-such-agent", "two-room", (), "x.json"), ctx).status == "agent not registered"
    assert (
        load_run(Run("rl-greedy", "two-room", ("--checkpoint", "none.pt"), "x.json", 0, "none.pt"), ctx).status
        == "no checkpoint"
    )


# ---- figures --------------------------------------------------------------------------------
def test_figures_draw_what_they_have_and_nothing_otherwise(tmp_path):
    run = lambda scale: [
        {
            "step": s,
            "success_rate": s / 1000,
            "task_return": scale * s / 1000,
            "selected_q": 3.0 * scale * s / 1000,
            "td_target": 3.0 * scale * s / 1000,
            "action_share": {"refill-water": 0.01 * s / 1000},
        }
        for s in range(0, 1001, 100)
    ]
    logs = {"two-room": {"myopic": {0: run(1), 4: run(2)}, "anticipatory": {0: run(3)}}}
    assert figs.training_curves(logs, tmp_path / "a1.png").stat().st_size > 1000
    assert figs.refill_share({"anticipatory": run(1)}, tmp_path / "a2.png", "refill-water").is_file()
    assert figs.refill_share({"anticipatory": run(1)}, tmp_path / "none.png", None) is None  # no [preparation]
    assert figs.training_curves({"two-room": {"myopic": {}}}, tmp_path / "none.png") is None
    assert figs.training_curves({"two-room": {"myopic": {0: []}}}, tmp_path / "none.png") is None
    assert figs.refill_share({}, tmp_path / "none.png", "refill-water") is None
    assert figs.greedy_vs_guided({"two-room": {}}, {}, tmp_path / "none.png") is None
    assert not (tmp_path / "none.png").exists()


def test_training_curves_count_every_run_and_put_a_diverged_q_on_a_log_axis(tmp_path, monkeypatch):
    """Figure A.1's legend counts the seeds drawn of every run behind the row (a run without a log here is
    counted, not drawn); a panel a diverged run takes past 1,000 is symlog, the others stay linear."""
    run = lambda q: [
        {"step": s, "success_rate": 0.5, "task_return": 1.0, "selected_q": q * s / 1000, "td_target": q * s / 1000}
        for s in range(0, 1001, 100)
    ]
    logs = {
        "three-room": {"myopic": {4: run(5e10), 8: [], 16: run(40.0)}, "anticipatory": {0: run(170.0), 4: []}},
        "two-room": {"myopic": {0: run(40.0)}, "anticipatory": {0: run(150.0)}},
    }
    monkeypatch.setattr(figs, "_save", lambda fig, path: fig)
    fig = figs.training_curves(logs, tmp_path / "a1.png")
    three, two = fig.axes[:4], fig.axes[4:]
    assert [t.get_text() for t in three[0].get_legend().get_texts()] == [
        "myopic: 2 of 3 seeds (4, 16)",
        "anticipatory: 1 of 2 seeds (0)",
    ]
    assert [ax.get_yscale() for ax in three] == ["linear", "linear", "symlog", "symlog"]
    assert [ax.get_yscale() for ax in two] == ["linear"] * 4
    assert [t.get_text() for t in two[0].get_legend().get_texts()] == [
        "myopic: 1 of 1 seed (0)",
        "anticipatory: 1 of 1 seed (0)",
    ]


def test_report_only_from_the_committed_results(tmp_path, monkeypatch):
    """`--report-only` on this checkout's results: every table and figure section, the augmented GNN row from
    its files (or 'not run' with its command), the myopic oracle's figure from its file, the PNGs written beside
    the report."""
    monkeypatch.chdir(ROOT)
    out = tmp_path / "results.md"
    start = time.perf_counter()
    text = report(["two-room", "three-room"], Context(), out, "python -m experiments.reproduce --report-only")
    assert time.perf_counter() - start < 120
    for heading in (
        "## Table 5.2",
        "## Table 5.3",
        "## Table A.4",
        "## Held-out seven",
        "## Share of the clairvoyant",
        "## Statistics",
        "## Figures",
        "## Task streams",
        "### three-room, stream cook-then-clean (markov)",
        "## Runs not yet made",
        "## Provenance of the results files",
    ):
        assert heading in text
    oracle = json.loads((ROOT / "results" / "myopic-oracle-two-room.json").read_text())["cost_per_task"]
    assert f"| Myopic oracle | {oracle:,.1f}" in text
    # the two-room augmented GNN row names every finished results file, or says "not run" with its command
    row = next(
        line for line in text.splitlines() if line.startswith("| One-task GNN (augmented, clause-library candidates) |")
    )
    files = [f.name for f in (ROOT / "results").glob("gnn-native-augmented-two-room-seed*-clause-library.json")]
    if files:
        assert all(f"`{name}`" in row for name in files) and f"{len(files)} of 4" in row
    else:
        assert "| not run" in row and "--agent gnn-native" in text
    for png in ("fig-5-1b-minimal-example.png", "fig-5-3-greedy-vs-guided.png", "fig-5-4-improvement.png"):
        assert (tmp_path / "figures" / png).is_file() and f"(figures/{png})" in text
    # the task streams' files have their provenance rows too (the † of a stream figure points there), each once
    prov = text.split("## Provenance of the results files")[1].splitlines()
    names = [line.split(" | ")[0] for line in prov if line.startswith("| `")]
    assert len(names) == len(set(names))
    for f in (ROOT / "results").glob("rl-guided-anticipatory-three-room-seed*-stream-cook-then-clean*.json"):
        assert f"| `{f.name}`" in names
    # a ranking under the Markov stream's contexts (learning.values.rank --stream) sits in that stream's section
    markov = text.split("### three-room, stream cook-then-clean (markov)")[1].split("\n### ")[0]
    for f in (ROOT / "results").glob("value-rank-three-room-*.json"):
        cond = json.loads(f.read_text()).get("conditional") or {}
        if cond.get("stream") == "cook-then-clean":
            after = next(r for r in cond["contexts"] if r["context"] == "after serve-water")
            assert f"(`{f.name}`; Spearman)" in markov
            assert f"| after serve-water | serve-water 0.60 | {after['exact_under_p']['spearman']:.3f} |" in markov


def test_training_curves_leave_out_runs_in_progress(tmp_path, monkeypatch):
    """Figure A.1 draws a seed's run once it is exported (finished), not while it trains; from the curve
    its results file keeps where it keeps one."""
    from experiments.report.specs import training_logs

    monkeypatch.chdir(tmp_path)
    (tmp_path / "results").mkdir()
    assert training_logs("two-room", "myopic") == []
    (tmp_path / "results" / "training-myopic-two-room-seed4.json").write_text("{}")
    assert training_logs("two-room", "myopic") == [(4, "runs/dqn/restaurant-two-room-myopic-seed4/metrics.jsonl")]
    assert training_logs("two-room", "anticipatory") == []
    (tmp_path / "results" / "training-myopic-two-room-seed4.json").write_text('{"curve": []}')  # kept with its curve
    assert training_logs("two-room", "myopic") == [(4, "results/training-myopic-two-room-seed4.json")]


def test_a_figure_from_training_logs_is_kept_where_the_logs_are_not(tmp_path):
    """runs/ is not committed: a fresh checkout lacking some of a figure's logs keeps the committed PNG rather
    than redrawing it from fewer runs; with every log here, or no PNG yet, it is drawn."""
    from experiments.report.thesis import from_logs

    png, log = tmp_path / "fig.png", tmp_path / "metrics.jsonl"
    drawn = []

    def draw(path):
        drawn.append(path)
        path.write_bytes(b"new")
        return path

    assert from_logs(draw, png, [str(log)]) == (png, 0) and png.read_bytes() == b"new"  # no PNG yet: drawn
    png.write_bytes(b"committed")
    assert from_logs(draw, png, [str(log), str(tmp_path / "other.jsonl")]) == (png, 2)
    assert png.read_bytes() == b"committed" and len(drawn) == 1  # kept, not redrawn
    log.write_text("{}")
    assert from_logs(draw, png, [str(log)]) == (png, 0) and png.read_bytes() == b"new"  # every log here


def test_a_bound_run_is_reported_beside_its_twin(tmp_path, monkeypatch):
    """The target-bound table pairs each bound run with the thesis-target run of its layout, horizon and seed,
    and says 'not run' for an evaluation not made."""
    from experiments.report.reference import target_bound_runs

    monkeypatch.chdir(tmp_path)
    (tmp_path / "results").mkdir()
    assert target_bound_runs()[0].startswith("No run with a target bound")
    write = lambda name, d: (tmp_path / "results" / name).write_text(json.dumps(d))
    for bound, q in (("none", 5.0e10), ("return", 42.4)):
        tail = "" if bound == "none" else "-bound-return"
        write(
            f"training-myopic-three-room-seed4{tail}.json",
            {
                "layout": "three-room",
                "horizon": "myopic",
                "seed": 4,
                "target_bound": bound,
                "peak_selected_q": {"step": 500_000, "selected_q": q},
                "at": {"500000": {"success_last_100": 0.5}},
            },
        )
    write("rl-greedy-myopic-three-room-seed4.json", {"success_rate": 0.148, "cost_per_task": 10332.95})
    write("rl-guided-myopic-three-room-seed4.json", {"cost_per_task": 1467.25, "improvement_vs_myopic": -0.035})
    rows = [line for line in target_bound_runs() if line.startswith("| three-room")]
    assert rows == [
        "| three-room | myopic | 4 | none | 50,000,000,000.0 | 0.50 | 14.8% | 10,333.0 | 1,467.2 | −3.5% |",
        "| three-room | myopic | 4 | return | 42.4 | 0.50 | not run | — | not run | — |",
    ]


def test_both_reports_open_and_close_with_their_provenance():
    """The header names the commit, the command as given, the date and the machine; the closing sections list
    the runs not yet made and one provenance row per results file (none here: the table's header alone)."""
    from experiments.report import provenance

    head = provenance.header("python -m experiments.reproduce --report-only")
    assert [line.split(":")[0] for line in head] == ["- commit", "- command", "- date", "- machine"]
    assert head[1] == "- command: `python -m experiments.reproduce --report-only`"
    assert provenance.closing({}) == [
        "## Runs not yet made",
        "",
        "Every run the tables expect has a results file.",
        "",
        "## Provenance of the results files",
        "",
        "| results file | use | failed-task accounting | commit | date | machine | command | configuration | "
        "checkpoint sha256 | flags (bold) and notes |",
        "|" + "---|" * 10,
        "",
    ]


# ---- task streams ---------------------------------------------------------------------------
def test_stream_rows_name_the_files_the_trainer_exports_and_the_evaluation_writes():
    """The stream section's runs: each estimator row's checkpoint is what learning.export names a run of that
    stream and estimator, its evaluation plays the stream with the estimator, the reference is the stream's."""
    from experiments.report import streams
    from learning.export import rl_name

    ctx = Context(str(ROOT / "domains" / "restaurant"))
    assert streams.stream_names(ctx.model("three-room")) == [
        ("iid", "iid"),
        ("cook-then-clean", "markov"),
        ("lunch-rush", "drift"),
    ]
    rows = {
        r.key: r for r in streams.rows(streams.names(ctx, "three-room", RL_SEEDS.__getitem__), "lunch-rush", "drift")
    }
    assert list(rows) == [
        "myopic-oracle",
        "clairvoyant-2",
        "clairvoyant-3",
        "iid-agent",
        "dep-empirical",
        f"dep-empirical-forget{streams.FORGET:g}",
        "est-empirical",
        f"est-empirical-forget{streams.FORGET:g}",
    ]
    oracle = rows["myopic-oracle"].runs[0]
    assert oracle.out == "results/myopic-oracle-internal-three-room-stream-lunch-rush.json"
    assert oracle.options == ("--planner", "internal", "--stream", "lunch-rush")
    # the i.i.d.-trained value deployed with the forgetting estimator: the thesis's checkpoint, the stream's play
    deploy = rows[f"dep-empirical-forget{streams.FORGET:g}"].runs[0]
    assert deploy.checkpoint == "checkpoints/rl-anticipatory-three-room-seed0.pt"
    assert deploy.command.endswith(
        "--estimator empirical --estimator-forget 0.95 --stream lunch-rush "
        "--out results/rl-guided-anticipatory-three-room-seed0-stream-lunch-rush-deploy-empirical-forget0.95.json"
    )
    run = rows[f"est-empirical-forget{streams.FORGET:g}"].runs[0]
    cfg = {
        "horizon": "anticipatory",
        "layout": "three-room",
        "seed": 0,
        "stream": "lunch-rush",
        "estimator": "empirical",
        "estimator_forget": streams.FORGET,
    }
    assert run.checkpoint == f"checkpoints/rl-{rl_name(cfg)}.pt"
    assert "--stream lunch-rush --estimator empirical --estimator-forget 0.95 &&" in run.train
    assert run.command.endswith(
        f"--estimator empirical --estimator-forget 0.95 --stream lunch-rush --out results/rl-guided-{rl_name(cfg)}.json"
    )
    iid = {r.key: r for r in streams.rows(streams.names(ctx, "two-room", RL_SEEDS.__getitem__), "iid", "iid")}
    assert [r.out for r in iid["iid-agent"].runs] == [
        f"results/rl-guided-anticipatory-two-room-seed{s}.json" for s in (0, 4, 8, 16)
    ]  # Table 5.2's own files
    assert "--stream" not in iid["est-empirical"].runs[0].options


def test_a_stream_run_is_played_on_its_stream_and_read_back(tiny):
    """reproduce's runner plays a stream row on that stream (the agent's config and file say so), and the report
    reads it back as the row's; the same file without the stream in its config is not taken for it."""
    ctx, _, _ = tiny
    run = Run("random", "two-room", ("--seed", "1", "--stream", "cook-then-clean"), "random-stream.json")
    row = Row("random", "Random", "two-room", (run,))
    assert run_missing([row], ctx, ids=[0, 1], progress=False) == [run.out]
    data = json.loads(Path(run.out).read_text())
    assert data["config"]["stream"] == "cook-then-clean"
    assert load_run(run, ctx).used
    plain = Run("random", "two-room", ("--seed", "1"), run.out)
    assert not load_run(plain, ctx).used


def test_table_a_5_reads_each_discount_runs_training_curve_greedy_and_guided_files(tmp_path, monkeypatch):
    """Seed 0 of γ = 0.9 exported and evaluated, seed 4 still training (its log): the row is the mean ± std of
    what both have, the jar share is counted in seed 0's guided plans, and the missing runs keep their commands."""
    from experiments.report.specs import DiscountRun
    from experiments.report.tables import discount_table
    from planning.domain.compiler import compile_domain
    from planning.world.preparation import Preparation

    model = compile_domain(ROOT / "domains/restaurant", "three-room")
    monkeypatch.chdir(tmp_path)
    done, training = DiscountRun(0.9, 0), DiscountRun(0.9, 4)
    Path("results").mkdir()
    curve = [{"step": s, "success_rate": s / 10_000, "selected_q": 30.0} for s in (5_000, 10_000)]
    Path(done.training).write_text(json.dumps({"curve": curve}))
    Path(done.greedy).write_text(json.dumps({"cost_per_task": 1500.0}))
    jar = ["refill-water(cup_0, jar_0, fountain)"] * 3 + ["fill(cup_1, water_fountain, fountain)"]
    Path(done.guided).write_text(json.dumps({"cost_per_task": 1200.0, "per_task": [{"plan": jar}]}))
    Path(training.log).parent.mkdir(parents=True)
    rows = [
        {"step": 1_000, "success_rate": 0.25, "selected_q": 10.0},
        {"step": 2_000, "success_rate": 0.35, "selected_q": 14.0},
    ]
    Path(training.log).write_text("".join(json.dumps(r) + "\n" for r in rows))
    lines = discount_table(Preparation.of(model))
    row = next(x for x in lines if x.startswith("| 0.90 |"))
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells[1] == "1 of 2; in training: 2,000 steps"
    assert cells[2] == f"{(0.75 + 0.3) / 2:.3f} ± {stats_std(0.75, 0.3):.3f}"  # each run's mean success
    assert cells[3] == f"{(30.0 + 12.0) / 2:.1f} ± {stats_std(30.0, 12.0):.1f}"
    assert cells[4:7] == ["1,500.0 (1 of 2)", "1,200.0 (1 of 2)", "75.0% (1 of 2)"]
    assert next(x for x in lines if x.startswith("| 0.95 |")).count("—") == 5
    assert any(done.evaluate not in x and training.evaluate in x for x in lines)
    assert not any(done.evaluate in x for x in lines)


def stats_std(a: float, b: float) -> float:
    return abs(a - b) / math.sqrt(2)  # the sample standard deviation of two values


def test_seeds_trained_together_are_reported_beside_their_ceiling(tmp_path, monkeypatch):
    """The batched trainer's ratio and the most batching could give from the single-seed matrix-product share:
    4 seeds at m = 0.5 cost 4 · 0.5 + 0.5 = 2.5 single updates, a ceiling of 1.60×."""
    from experiments.report.reference import seeds_together

    monkeypatch.chdir(tmp_path)
    assert seeds_together() == []  # no benchmark, no table
    Path("results").mkdir()
    r = {"seeds": 4, "single_updates_per_s": 100.0, "aggregate_updates_per_s": 120.0, "ratio": 1.2}
    seeds = {"threads": 1, "seeds": {"anticipatory": r}, "provenance": {"command": "python -m learning.q.bench X"}}
    Path("results/dqn-bench-seeds-two-room.json").write_text(json.dumps(seeds))
    Path("results/dqn-bench-two-room.json").write_text(
        json.dumps({"anticipatory": {"competent": {"matmul_share": 0.5}}})
    )
    row = next(x for x in seeds_together() if x.startswith("| two-room |"))
    assert [c.strip() for c in row.strip("|").split("|")] == [
        "two-room",
        "anticipatory",
        "4",
        "100.0",
        "120.0",
        "1.20×",
        "1.60× (m = 50%)",
    ]
    assert any("`python -m learning.q.bench X`" in x for x in seeds_together())


def test_a_drifting_streams_rows_are_tested_again_after_the_change():
    """Two four-task sequences whose change comes at task 2: the forgetting row costs more before it and less
    after; cut at the change, its results hold only tasks 2 and 3, and it is paired with its stationary twin."""
    from experiments.report.data import Loaded, RowResult
    from experiments.report.streams import forgetting_pairs, from_position

    def row(key, costs):  # costs[sequence] = the four tasks' costs
        per_task = [{"sequence": s, "index": i, "cost": c} for s, cs in enumerate(costs) for i, c in enumerate(cs)]
        per_sequence = [{"id": s, "cost": sum(cs), "tasks": len(cs)} for s, cs in enumerate(costs)]
        run = Run("rl-guided", "three-room", out=f"{key}.json", seed=0)
        data = {"per_task": per_task, "per_sequence": per_sequence}
        return RowResult(Row(key, key, "three-room", (run,), seeded=True), [Loaded(run, "ok", data)])

    rows = {
        "iid-agent": row("iid-agent", [[9, 9, 9, 9], [9, 9, 9, 9]]),
        "est-empirical": row("est-empirical", [[1, 1, 8, 8], [1, 1, 6, 6]]),
        "est-empirical-forget0.95": row("est-empirical-forget0.95", [[2, 2, 5, 5], [2, 2, 4, 4]]),
        "dep-empirical-forget0.95": row("dep-empirical-forget0.95", [[2, 2, 5, 5], [2, 2, 4, 4]]),
    }
    assert forgetting_pairs(rows) == [("est-empirical-forget0.95", "est-empirical")]  # dep- has no twin here
    after = from_position(rows["est-empirical-forget0.95"], 2)
    assert after.used[0]["per_sequence"] == [{"id": 0, "cost": 10.0, "tasks": 2}, {"id": 1, "cost": 8.0, "tasks": 2}]
    assert rows["est-empirical-forget0.95"].used[0]["per_sequence"][0]["cost"] == 14  # the row itself is uncut

"""Task streams of domain.toml (`planning.world.streams`) and the distribution estimators
(`planning.world.estimators`): on hand-made chains, a small copy of the grid domain and the restaurant's
declared streams."""

import shutil
import tomllib
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from planning.domain.compiler import compile_domain
from planning.errors import DomainError
from planning.world import sequences
from planning.world.estimators import build, tracking
from planning.world.streams import stationary, stream, streams
from planning.world.task_stream import TaskStream, draw_tasks
from tests.conftest import MINIMAL, declare_grid_streams

ROOT = Path(__file__).resolve().parents[2]


def grid_with_streams(tmp_path, blend="step", extra=""):
    """The minimal grid domain with both task types drawn (clear 0.3, deliver 0.7) and two streams."""
    folder = tmp_path / "grid"
    shutil.copytree(ROOT / MINIMAL, folder)
    declare_grid_streams(folder, blend, extra)
    return compile_domain(folder, "grid")


def test_the_stationary_distribution_of_a_small_chain_is_exact():
    assert np.allclose(stationary(np.array([[0.9, 0.1], [0.5, 0.5]])), [5 / 6, 1 / 6], atol=1e-12)
    T = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])  # a cycle: uniform
    assert np.allclose(stationary(T), [1 / 3] * 3, atol=1e-12)
    with pytest.raises(DomainError, match="no unique stationary"):
        stationary(np.eye(2))  # two closed classes


def test_a_markov_stream_on_another_domain(tmp_path):
    model = grid_with_streams(tmp_path)
    s = stream(model, "alternate")
    assert s.types == ["clear", "deliver"]
    assert np.allclose(s.start, [5 / 14, 9 / 14])  # stationary of the table: pi = (0.5/1.4, 0.9/1.4)
    clear, deliver_b = model.tasks.get("clear(c)"), model.tasks.get("deliver(b)")
    after_clear = s.probabilities(clear)
    assert after_clear[clear.index] == pytest.approx(0.1)
    assert after_clear[deliver_b.index] == pytest.approx(0.9 * 0.8)  # arguments as [tasks]: b 0.8
    assert after_clear.sum() == pytest.approx(1.0)
    # drawn: transition frequencies match the table
    tasks = draw_tasks(model, 3, 4000, s)
    pairs = [(a.type, b.type) for a, b in zip(tasks, tasks[1:])]
    from_clear = [b for a, b in pairs if a == "clear"]
    assert abs(from_clear.count("deliver") / len(from_clear) - 0.9) < 0.03


@pytest.mark.parametrize("blend", ["step", "linear"])
def test_a_drifting_stream_changes_its_mix_with_the_position(tmp_path, blend):
    model = grid_with_streams(tmp_path, blend)
    s = stream(model, "shift")
    clear = model.tasks.get("clear(c)").index
    assert s.probabilities(None, 0)[clear] == 1.0
    assert s.probabilities(None, 5)[clear] == (1.0 if blend == "step" else pytest.approx(0.5))
    assert s.probabilities(None, 10)[clear] == 0.0 and s.probabilities(None, 40)[clear] == 0.0
    drawn = draw_tasks(model, 0, 20, s)
    assert [t.type for t in drawn[10:]] == ["deliver"] * 10 and drawn[0].type == "clear"


def test_the_iid_stream_draws_as_before(two_room):
    """The i.i.d. stream samples exactly as TaskDistribution.sample: today's canonical sequences, bit for bit."""
    iid = stream(two_room, None)
    assert [t.name for t in draw_tasks(two_room, 1000, 50, iid)] == [t.name for t in draw_tasks(two_room, 1000, 50)]
    a, b = TaskStream(two_room, 7), TaskStream(two_room, 7, iid)
    assert [a.next()[0].name for _ in range(120)] == [b.next()[0].name for _ in range(120)]


@pytest.mark.parametrize(
    "extra, match",
    [
        ('\n[streams.bad]\nkind = "markov"\n[streams.bad.transitions]\nclear = { clear = 1.0 }\n', "one row per type"),
        (
            '\n[streams.bad]\nkind = "markov"\n[streams.bad.transitions]\n'
            "clear = { clear = 0.5 }\ndeliver = { deliver = 1.0 }\n",
            "sums to 0.5",
        ),
        ('\n[streams.bad]\nkind = "drift"\nphases = [{ from = 3, types = { clear = 1.0 } }]\n', "start at from = 0"),
        ('\n[streams.bad]\nkind = "drift"\nphases = [{ from = 0, types = { pick = 1.0 } }]\n', "'pick' is not a task"),
        ('\n[streams.bad]\nkind = "sometimes"\n', "not one of markov, drift"),
        ('\n[streams.iid]\nkind = "drift"\n', "choose another"),
    ],
)
def test_a_bad_stream_is_a_one_line_error(tmp_path, extra, match):
    model = grid_with_streams(tmp_path, extra=extra)
    with pytest.raises(DomainError, match=match) as e:
        streams(model)
    assert "\n" not in str(e.value) and "domain.toml" in str(e.value)


def test_the_restaurants_markov_sequences_follow_their_table(three_room):
    """The stored cook-then-clean sequences: the type transitions over all ten agree with the table (a chi-square
    goodness-of-fit test over the rows with enough transitions), and they regenerate as stored."""
    s = stream(three_room, "cook-then-clean")
    seqs = sequences.load(three_room, stream_name="cook-then-clean")
    assert len(seqs) == 10 and all(len(q.tasks) == 50 for q in seqs)
    counts = np.zeros((len(s.types), len(s.types)))
    for q in seqs:
        for a, b in zip(q.tasks, q.tasks[1:]):
            counts[s.types.index(a.type), s.types.index(b.type)] += 1
    chi, dof = 0.0, 0
    for k, row in enumerate(counts):
        if row.sum() < 40:
            continue
        expected = row.sum() * s.transitions[k]
        keep = expected > 0
        chi += float(((row[keep] - expected[keep]) ** 2 / expected[keep]).sum())
        dof += int(keep.sum()) - 1
    assert dof > 5 and stats.chi2.sf(chi, dof) > 0.001
    assert [r["tasks"] for r in sequences.generate(three_room, stream_name="cook-then-clean")] == [
        [t.name for t in q.tasks] for q in seqs
    ]


def test_restaurant_streams_are_declared_over_its_task_types(two_room):
    table = tomllib.loads((ROOT / "domains/restaurant/domain.toml").read_text())["streams"]
    assert set(table) == {"cook-then-clean", "lunch-rush"}
    s = streams(two_room)
    assert s["cook-then-clean"].stationary().sum() == pytest.approx(1.0)
    rush = s["lunch-rush"]
    water = rush.types.index("serve-water")
    assert rush.type_probabilities(None, 24)[water] == 0.25 and rush.type_probabilities(None, 25)[water] == 0.55


# ---- estimators -----------------------------------------------------------------------------------
def test_the_known_estimator_is_the_layouts_distribution(two_room):
    est = build("known", two_room)
    p = np.asarray(two_room.tasks.probabilities, dtype=float)
    est.observe(two_room.tasks[0])
    assert np.array_equal(est.probabilities(two_room.tasks[0]), p / p.sum())


def test_the_empirical_estimator_counts_with_a_prior_and_forgets(tmp_path):
    model = grid_with_streams(tmp_path)  # three instances, all in the support
    c, b, a = (model.tasks.get(n) for n in ("clear(c)", "deliver(b)", "deliver(a)"))
    est = build("empirical", model, prior=3.0)
    assert np.allclose(est.probabilities(), [1 / 3] * 3)  # from nothing: uniform over the support
    for t in (c, c, b):
        est.observe(t)
    p = est.probabilities()
    assert (
        p[c.index] == pytest.approx(3 / 6) and p[b.index] == pytest.approx(2 / 6) and p[a.index] == pytest.approx(1 / 6)
    )
    forgetful = build("empirical", model, prior=3.0, forget=0.5)
    for t in (c, c, b):
        forgetful.observe(t)  # counts: c 0.5 + 1 = 1.5 then 0.75, b 1
    p = forgetful.probabilities()
    assert p[c.index] == pytest.approx(1.75 / 4.75) and p[b.index] == pytest.approx(2 / 4.75)
    state = forgetful.state_dict()
    again = build("empirical", model, prior=3.0, forget=0.5)
    again.load_state_dict(state)
    assert np.array_equal(again.probabilities(), p)


def test_the_markov_estimators_condition_on_the_task_before(tmp_path):
    model = grid_with_streams(tmp_path)
    s = stream(model, "alternate")
    c, b = model.tasks.get("clear(c)"), model.tasks.get("deliver(b)")
    known = build("markov", model, s)
    assert np.array_equal(known.probabilities(c), s.probabilities(c))
    with pytest.raises(DomainError, match="needs a Markov stream"):
        build("markov", model, stream(model, "shift"))
    learned = build("markov-empirical", model, prior=3.0)
    for t in (c, b, c, b):
        learned.observe(t)
    learned.restart()  # a reset: no transition into the next sequence's first task
    learned.observe(b)
    learned.observe(c)
    after_c, after_b = learned.probabilities(c), learned.probabilities(b)
    assert after_c.sum() == pytest.approx(1.0) and after_b.sum() == pytest.approx(1.0)
    # types: clear -> deliver twice, deliver -> clear twice (one after the restart), each row with 1.5 of the 3
    # pseudo-counts on each type; arguments: c 3, b 3, a 0 seen, plus 1 each, so deliver(b) is 4/5 of deliveries
    assert learned.transitions.sum() == 4 and learned.counts.sum() == 6
    assert after_c[b.index] == pytest.approx(3.5 / 5 * 4 / 5)
    assert after_c[c.index] == pytest.approx(1.5 / 5)
    assert after_b[c.index] == pytest.approx(3.5 / 5)
    a = model.tasks.get("deliver(a)")
    assert after_b[a.index] == pytest.approx(1.5 / 5 * 1 / 5)
    resumed = build("markov-empirical", model, prior=3.0)
    resumed.load_state_dict(learned.state_dict())
    assert np.array_equal(resumed.probabilities(c), after_c) and resumed.last == c


def test_tracking_measures_how_far_an_estimate_is_from_the_stream(tmp_path):
    model = grid_with_streams(tmp_path)  # clear(c) 0.3, deliver(b) 0.56, deliver(a) 0.14
    shift = stream(model, "shift")  # clear until position 10, then deliver (b 0.8, a 0.2)
    c, b = model.tasks.get("clear(c)"), model.tasks.get("deliver(b)")
    seq = [c] * 10 + [b] * 10
    known = tracking(lambda: build("known", model), shift, [seq])
    assert len(known["types"]) == 19  # positions 1 to 19
    assert np.allclose(known["types"][:9], 0.7) and np.allclose(known["instances"][:9], 0.7)
    assert np.allclose(known["types"][9:], 0.3) and np.allclose(known["instances"][9:], 0.5 * (0.3 + 0.24 + 0.06))
    counted = tracking(lambda: build("empirical", model), shift, [seq, seq])  # prior 1: a third on each instance
    p = np.arange(1, 10)
    assert np.allclose(counted["types"][:9], (2 / 3) / (p + 1))  # p clears seen: 1 - (p + 1/3) / (p + 1)
    assert counted["instances"][9] == pytest.approx(31 / 33)  # ten clears seen, a delivery due
    assert counted["types"][14] == pytest.approx(31 / 48)  # position 15: clear 10 + 1/3 of 16
    forgetful = tracking(lambda: build("empirical", model, forget=0.5), shift, [seq])
    left = 2 * (1 - 0.5**10) * 0.5**5  # the clears' weight after five deliveries
    assert forgetful["types"][14] == pytest.approx((left + 1 / 3) / (left + 2 * (1 - 0.5**5) + 1))
    assert forgetful["types"][14] < counted["types"][14] / 4  # forgetting recovers after the change (the prior stays)
    alternate = stream(model, "alternate")
    drawn = draw_tasks(model, 5, 30, alternate)
    exact = tracking(lambda: build("markov", model, alternate), alternate, [drawn])
    assert np.array_equal(exact["instances"], np.zeros(29))  # the known table is the stream's own


def test_a_type_never_drawn_gets_no_probability_from_the_learned_estimators(minimal):
    """The minimal grid draws deliveries only (clear has P = 0): every estimate is zero on clear, finite, and
    sums to one, before and after tasks are seen."""
    deliver = next(t for t in minimal.tasks if t.type == "deliver")
    for name in ("empirical", "markov-empirical"):
        est = build(name, minimal)
        for p in (est.probabilities(), est.observe(deliver) or est.probabilities(deliver)):
            assert np.isfinite(p).all() and p.sum() == pytest.approx(1.0)
            assert all(p[t.index] == 0 for t in minimal.tasks if t.type == "clear")

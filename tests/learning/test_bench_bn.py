"""learning.agents.bench_bn: the search timed against the reference implementation in the same run."""

from pathlib import Path

import pytest


def test_benchmark_reports_the_ratio_and_the_same_plans(two_room):
    pytest.importorskip("torch")
    ckpt = Path("checkpoints/rl-anticipatory-two-room-seed0.pt")
    if not ckpt.is_file():
        pytest.skip(f"no {ckpt}")
    from learning.agents.bench_bn import benchmark
    from learning.q.value import load_value_function
    from planning.parallel import one_thread
    from planning.world.sequences import load

    one_thread()
    value = load_value_function(ckpt, two_room)
    seq = load(two_room, [0])[0]
    r = benchmark(two_room, value, seq.tasks[:4], seq.reset_seed, budget=300, beta=1.25, progress=False)
    assert r["searched_tasks"] >= 3 and r["same_plans"] == r["searched_tasks"]
    for key in ("speedup", "speedup_no_memo"):
        assert r[key]["per_expansion"] > 0 and r[key]["cpu"] > 0
    assert r["reference_implementation"]["expansions_per_s"] > 0
    assert all(t["expansions"] == 300 for t in r["per_task"])
    alone = benchmark(
        two_room, value, seq.tasks[:2], seq.reset_seed, budget=100, beta=1.25, progress=False, reference=False
    )
    assert "speedup" not in alone and alone["searched_tasks"] >= 1


def test_the_search_takes_a_value_evaluated_in_torch(two_room):
    """bench_bn --device: the compiled search calls a value on a device through q_max (no native engine); here
    torch's CPU kernels stand in for a GPU."""
    ckpt = Path("checkpoints/rl-anticipatory-two-room-seed0.pt")
    if not ckpt.is_file():
        pytest.skip(f"no {ckpt}")
    from learning.agents.bench_bn import benchmark
    from learning.q.value import load_value_function
    from planning.world.sequences import load

    value = load_value_function(ckpt, two_room).to_device("cpu")
    seq = load(two_room, [0])[0]
    r = benchmark(
        two_room, value, seq.tasks[:2], seq.reset_seed, budget=100, beta=1.25, progress=False, reference=False
    )
    assert r["searched_tasks"] >= 1 and r["value_calls_per_task"] > 0
    assert all(t["expansions"] == 100 for t in r["per_task"])

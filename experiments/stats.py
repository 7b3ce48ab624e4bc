"""The thesis's statistics (§5.4.3) for any two results sets: paired over sequences, and across seeds.

A *results set* is a list of results JSONs of one agent on one layout, one per
seed (an oracle has one). Two tests, as the thesis reports them:

- over sequences: each sequence's cost per task averaged over the set's seeds,
  the two sets paired by sequence, an exact two-sided Wilcoxon signed-rank test
  (scipy; at n = 10 with every pair one way p = 2/2^10 = 0.002, at n = 7
  p = 2/2^7 = 0.0156);
- across seeds: each seed's cost per task over the sequences, Welch's t of the
  two sets, and the 95% interval of the difference of means divided by the
  second set's mean: the interval of the relative reduction (1 − A/B). From the
  thesis's own Table 5.2 figures (978 ± 127 over 5 seeds against 1,308 ± 1
  over 4) this gives t(4) = 5.8 and 13.1%–37.3%, the interval it reports.
"""

from __future__ import annotations

import math

from scipy import stats


def sequence_costs(results: list[dict], ids=None) -> dict[int, float]:
    """{sequence id: cost per task averaged over the results (seeds)}, for the sequences every one holds
    (restricted to `ids` when given)."""
    if not results:
        return {}
    tables = [{s["id"]: s["cost"] / s["tasks"] for s in r["per_sequence"] if s["tasks"]} for r in results]
    common = set.intersection(*(set(t) for t in tables))
    if ids is not None:
        common &= set(ids)
    return {i: sum(t[i] for t in tables) / len(tables) for i in sorted(common)}


def seed_costs(results: list[dict], ids=None) -> list[float]:
    """Each result's (seed's) cost per task over the sequences `ids` (default: all it holds)."""
    out = []
    for r in results:
        seqs = [s for s in r["per_sequence"] if ids is None or s["id"] in set(ids)]
        tasks = sum(s["tasks"] for s in seqs)
        if tasks:
            out.append(sum(s["cost"] for s in seqs) / tasks)
    return out


def wilcoxon_paired(a: dict[int, float], b: dict[int, float]) -> dict:
    """Exact two-sided Wilcoxon signed-rank test of A against B over the sequences both hold.

    Returns n, the sequences, how many A is cheaper on, the statistic (the smaller rank sum), p, and
    the smallest p attainable at this n; `reason` instead of p where the test cannot be made.
    """
    ids = sorted(set(a) & set(b))
    out = {
        "n": len(ids),
        "sequences": ids,
        "a_cheaper": sum(a[i] < b[i] for i in ids),
        "b_cheaper": sum(b[i] < a[i] for i in ids),
    }
    if len(ids) < 2:
        return {**out, "reason": f"{len(ids)} paired sequences (needs at least 2)"}
    if all(a[i] == b[i] for i in ids):
        return {**out, "reason": "the two sets cost the same on every sequence"}
    res = stats.wilcoxon([a[i] for i in ids], [b[i] for i in ids], alternative="two-sided", method="exact")
    return {**out, "statistic": float(res.statistic), "p": float(res.pvalue), "min_p": 2 / 2 ** len(ids)}


def welch_from_stats(
    mean_a: float, sd_a: float, n_a: int, mean_b: float, sd_b: float, n_b: int, level: float = 0.95
) -> dict:
    """Welch's t of B − A from summary statistics (sample standard deviations), its df and two-sided p,
    the reduction 1 − A/B and its `level` interval (the interval of B − A divided by B's mean)."""
    va, vb = sd_a**2 / n_a, sd_b**2 / n_b
    se = math.sqrt(va + vb)
    diff = mean_b - mean_a
    out = {"n_a": n_a, "n_b": n_b, "mean_a": mean_a, "mean_b": mean_b, "reduction": diff / mean_b}
    if se == 0:
        return {**out, "reason": "no spread across seeds on either side"}
    df = (va + vb) ** 2 / (va**2 / (n_a - 1) + vb**2 / (n_b - 1))
    t = diff / se
    q = stats.t.ppf(0.5 + level / 2, df)
    return {
        **out,
        "t": t,
        "df": df,
        "p": float(2 * stats.t.sf(abs(t), df)),
        "se": se,
        "ci": ((diff - q * se) / mean_b, (diff + q * se) / mean_b),
        "level": level,
    }


def welch_seeds(a: list[float], b: list[float], level: float = 0.95) -> dict:
    """Welch's t across seeds (one cost per task per seed on each side); `reason` where it cannot be made."""
    if len(a) < 2 or len(b) < 2:
        mean = lambda xs: sum(xs) / len(xs) if xs else float("nan")
        return {
            "n_a": len(a),
            "n_b": len(b),
            "mean_a": mean(a),
            "mean_b": mean(b),
            "reduction": 1 - mean(a) / mean(b) if a and b else None,
            "reason": f"not computable: {len(a)} and {len(b)} seeds (needs at least 2 on each side)",
        }
    sd = lambda xs: math.sqrt(sum((x - sum(xs) / len(xs)) ** 2 for x in xs) / (len(xs) - 1))
    return welch_from_stats(sum(a) / len(a), sd(a), len(a), sum(b) / len(b), sd(b), len(b), level)


def compare(a: list[dict], b: list[dict], ids=None) -> dict:
    """Both tests of results set A against B on the sequences `ids` (default: all both hold)."""
    pa, pb = sequence_costs(a, ids), sequence_costs(b, ids)
    common = sorted(set(pa) & set(pb))
    return {"wilcoxon": wilcoxon_paired(pa, pb), "welch": welch_seeds(seed_costs(a, common), seed_costs(b, common))}

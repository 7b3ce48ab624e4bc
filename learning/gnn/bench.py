"""Benchmark and check of a trained GNN estimator against the exact C_AP it imitates.

    python -m learning.gnn.bench --model checkpoints/gnn-faithful-three-room-seed0.pt \
        --data runs/gnn/three-room-faithful [--batch 50] [--repeats 20] [--exact 50] [--out FILE]

On the validation states of the model's own training run (the seeded 80/20 split of
`learning.gnn_train`, states it never trained on), in one process:

- inference: a batch of `--batch` states through `GNNValue.c_ap` (graph encoding,
  collation, one forward pass), split into encoding and forward, median of `--repeats`;
- the reference in the same run: the exact C_AP of `--exact` of those states by the
  labelling oracle's multi-goal search (`oracles.labelling.Labeller`), per state, and
  the ratio of the two per-state costs;
- accuracy: the mean absolute error of Ĉ_AP against the dataset's exact labels over the
  whole validation split, the Spearman and Kendall rank correlations, and how often the
  model orders a pair of states as the exact labels do (pairs whose labels differ).

Times are this process's CPU time with one torch thread.
"""

from __future__ import annotations

import platform
import time
from pathlib import Path

import numpy as np
import torch
from scipy import stats

from planning import cli
from planning.atomic import write_json
from planning.domain.compiler import compile_domain
from planning.errors import DomainError
from planning.parallel import results_provenance


def cpu(fn, repeats: int) -> float:
    """Median CPU seconds of fn() over repeats."""
    out = []
    for _ in range(repeats):
        t = time.process_time()
        fn()
        out.append(time.process_time() - t)
    return float(np.median(out))


def pair_agreement(est: np.ndarray, exact: np.ndarray) -> float:
    """Share of the pairs with different exact labels that the estimate orders the same way."""
    i, j = np.triu_indices(len(exact), 1)
    d = np.sign(exact[i] - exact[j])
    keep = d != 0
    return float(np.mean(np.sign(est[i] - est[j])[keep] == d[keep]))


def bench(model_path: str, data: str, domain: str, batch: int, repeats: int, n_exact: int, encoder=None) -> dict:
    """The figures of the module's docstring (`encoder`: the layout's GraphEncoder, default GNNValue's)."""
    from learning.gnn.dataset import read_meta
    from learning.gnn.model import check_made_for
    from learning.gnn.training import split
    from learning.gnn.value import GNNValue, collate, model_summary
    from oracles.labelling import Labeller

    meta_path = Path(data) / "meta.json"
    meta = read_meta(data)
    if not isinstance(meta.get("layout"), str) or not all(k in meta for k in ("n", "atoms", "c_ap")):
        raise DomainError(meta_path, "not a gnn_dataset's metadata (layout, n, atoms and c_ap expected)")
    model = compile_domain(domain, meta["layout"])
    check_made_for(meta_path, meta, model, "dataset")
    value = GNNValue(model_path, model, encoder)  # a model of another layout stops here
    cfg = value.payload.get("config", {})
    _, val = split(meta["n"], int(cfg.get("seed", 0)), float(cfg.get("val_fraction", 0.2)))
    states = [model.state_from_atoms(meta["atoms"][i]) for i in val]
    exact = np.asarray(meta["c_ap"], dtype=float)[val]
    ok = np.isfinite(exact)

    # accuracy on the whole validation split: one pass, fresh cache
    est = value.c_ap(states)
    err = np.abs(est - exact)[ok]
    accuracy = {
        "states": int(ok.sum()),
        "mae": round(float(err.mean()), 2),
        "median_abs_error": round(float(np.median(err)), 2),
        "exact_mean": round(float(exact[ok].mean()), 2),
        "spearman": round(float(stats.spearmanr(est[ok], exact[ok])[0]), 4),
        "kendall": round(float(stats.kendalltau(est[ok], exact[ok])[0]), 4),
        "pair_agreement": round(pair_agreement(est[ok], exact[ok]), 4),
    }

    # inference time of a batch, encoding and forward apart
    some = states[:batch]
    enc = lambda: collate([value.encoder.arrays(s) for s in some])
    x, index, attr, b = enc()

    def module_forward():
        with torch.no_grad():
            value.net(x, index, b, attr, num_graphs=len(some))

    def forward():
        value.inference(x, index, b, attr, num_graphs=len(some))

    def whole():
        value._cache.clear()
        value.c_ap(some)

    inference = {
        "batch": len(some),
        "encode_ms": round(1e3 * cpu(enc, repeats), 3),
        "forward_ms": round(1e3 * cpu(forward, repeats), 3),
        "module_forward_ms": round(1e3 * cpu(module_forward, repeats), 3),
        "c_ap_ms": round(1e3 * cpu(whole, repeats), 3),
    }
    inference["per_state_ms"] = round(inference["c_ap_ms"] / len(some), 4)

    labeller = Labeller(model)
    labeller.label(states[0])  # builds the pattern databases, outside the clock
    t = time.process_time()
    labels = [labeller.label(s).c_ap for s in states[:n_exact]]
    exact_ms = 1e3 * (time.process_time() - t) / max(1, len(labels))
    if not np.allclose(labels, exact[: len(labels)], equal_nan=True):
        raise DomainError(meta_path, "its labels are not the labelling oracle's C_AP of its states")
    return {
        "model": model_summary(model_path),
        "data": data,
        "layout": model.layout,
        "domain": model.name,
        "threads": torch.get_num_threads(),
        "machine": f"{platform.machine()} {platform.python_implementation()} {platform.python_version()}",
        "validation": accuracy,
        "inference": inference,
        "exact": {
            "states": len(labels),
            "per_state_ms": round(exact_ms, 2),
            "ratio_to_gnn": round(exact_ms / inference["per_state_ms"], 1),
        },
    }


def main() -> None:
    p = cli.parser(
        __doc__.splitlines()[0],
        layout=False,
        helps={"out": "results JSON (default: results/bench-gnn-<model name>.json)"},
    )
    p.add_argument("--model", required=True, help="GNN checkpoint (learning.gnn_train's best.pt)")
    p.add_argument("--data", required=True, help="the learning.gnn_dataset folder it was trained on")
    p.add_argument("--batch", type=int, default=50, help="states per inference batch (default: %(default)s)")
    p.add_argument("--repeats", type=int, default=20, help="timed repeats (default: %(default)s)")
    p.add_argument(
        "--exact", type=int, default=50, help="states labelled exactly for the reference (default: %(default)s)"
    )

    def run():
        args = p.parse_args()
        torch.set_num_threads(1)
        out = Path(args.out or f"results/bench-gnn-{Path(args.model).stem.removeprefix('gnn-')}.json")
        cli.check_writable(out)
        r = bench(args.model, args.data, args.domain, args.batch, args.repeats, args.exact)
        write_json(out, {**r, "provenance": results_provenance({"model": args.model})})
        a, i, e = r["validation"], r["inference"], r["exact"]
        print(
            f"{r['layout']} validation ({a['states']} states): MAE {a['mae']} (exact mean {a['exact_mean']}), "
            f"Spearman {a['spearman']}, pairs ordered right {a['pair_agreement']:.1%} | batch of {i['batch']}: "
            f"{i['c_ap_ms']} ms (encode {i['encode_ms']}, forward {i['forward_ms']}, the module's "
            f"{i['module_forward_ms']}) | exact C_AP {e['per_state_ms']} ms/state, {e['ratio_to_gnn']}x the GNN's; "
            f"wrote {out}"
        )

    cli.run(run)


if __name__ == "__main__":
    main()

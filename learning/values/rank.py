"""How well a value ranks states by preparedness: its V_AP against the exact C_AP.

    python -m learning.values.rank --data runs/gnn/three-room-faithful \
        --value checkpoints/rl-anticipatory-three-room-seed0.pt [--value KIND:PATH ...] [--out FILE]

The value-guided search uses a value only to rank the terminal states it reaches
(thesis §4.2), so what matters is the order V_AP puts states in. The labelled
states of a `learning.gnn_dataset` folder carry their exact one-task C_AP (the
labelling oracle, all task instantiations): how much the next task is expected
to cost from there. A value that knows preparedness ranks a state with a lower
C_AP higher. Per value (any of the value registry, `learning.values`: a bare
checkpoint path is a Q-network's of learning.dqn or a GNN's of learning.gnn_train,
whose V_AP is -Ĉ_AP, by what its file says; `exact` on small domains):

- the Spearman and Kendall rank correlations of V_AP with -C_AP, and the share
  of the pairs of states with different C_AP that V_AP orders the same way;
- the slope of V_AP on -C_AP (least squares, RL units per PDDL unit): a
  multi-task value credits a lower next-task cost over the tasks after it too,
  so its slope exceeds 1/cost_scale, the one-task credit;
- the same per kind of state (an augmented dataset's prepared states apart).

C_AP is a one-task cost, V_AP a discounted multi-task value, so the two need not
agree state by state; a value that ranks prepared states below unprepared ones
on a whole kind of states does not know that preparation. A GNN checkpoint
trained on these states is scored on its validation split only.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch
from scipy import stats

from learning.values import HELP, load_value
from planning import cli
from planning.atomic import write_json
from planning.domain.compiler import compile_domain
from planning.errors import DomainError
from planning.parallel import results_provenance


def agreement(v: np.ndarray, c_ap: np.ndarray) -> dict:
    """Rank agreement of a value with -C_AP over a set of states (see the module's docstring)."""
    from learning.gnn.bench import pair_agreement

    if len(v) < 3:
        return {"states": int(len(v))}
    slope = np.polyfit(-c_ap, v, 1)[0]
    return {
        "states": int(len(v)),
        "spearman": round(float(stats.spearmanr(v, -c_ap)[0]), 4),
        "kendall": round(float(stats.kendalltau(v, -c_ap)[0]), 4),
        "pair_agreement": round(pair_agreement(v, -c_ap), 4),
        "slope_rl_per_pddl": round(float(slope), 5),
    }


def rank(values: list, data: str, domain: str) -> dict:
    """The figures of the module's docstring, per value (a value's name, KIND:PATH, KIND or a checkpoint
    path, or any object of the Value protocol), over the dataset's labelled states."""
    from learning.gnn.dataset import read_meta
    from learning.gnn.model import check_made_for

    meta_path = Path(data) / "meta.json"
    meta = read_meta(data)
    try:
        layout, atoms, labels = meta["layout"], meta["atoms"], np.asarray(meta["c_ap"], dtype=float)
    except (ValueError, KeyError, TypeError) as e:
        raise DomainError(meta_path, f"not a learning.gnn_dataset folder ({type(e).__name__})") from None
    model = compile_domain(domain, layout)
    check_made_for(meta_path, meta, model, "dataset")
    states = [model.state_from_atoms(a) for a in atoms]
    kinds = np.asarray(meta.get("kinds") or ["all"] * len(states))
    out = {
        "data": data,
        "domain": model.name,
        "layout": model.layout,
        "cost_scale": model.cost_scale,
        "states": len(states),
        "kinds": {k: int((kinds == k).sum()) for k in dict.fromkeys(kinds.tolist())},
        "values": [],
    }
    for value in values:
        name = str(value) if isinstance(value, (str, Path)) else type(value).__name__
        if isinstance(value, (str, Path)):
            value = load_value(str(value), model)
        keep = np.isfinite(labels)
        row = {"value": name, "kind": type(value).__name__, "gamma": value.gamma}
        payload = getattr(value, "payload", None)
        if payload is not None and Path(payload.get("config", {}).get("data", "")).resolve() == Path(data).resolve():
            from learning.gnn.training import split

            cfg = payload["config"]
            _, val = split(len(states), int(cfg.get("seed", 0)), float(cfg.get("val_fraction", 0.2)))
            only = np.zeros(len(states), dtype=bool)
            only[val] = True
            keep &= only
            row["scored_on"] = "the validation split of its own training run"
        idx = np.flatnonzero(keep)
        v = np.asarray(value.v_ap([states[i] for i in idx]), dtype=float)
        row["all"] = agreement(v, labels[idx])
        row["by_kind"] = {
            k: agreement(v[kinds[idx] == k], labels[idx][kinds[idx] == k])
            for k in out["kinds"]
            if len(out["kinds"]) > 1
        }
        out["values"].append(row)
    return out


def main() -> None:
    p = cli.parser(
        __doc__.splitlines()[0],
        layout=False,
        helps={"out": "results JSON (default: results/value-rank-<dataset folder name>.json)"},
    )
    p.add_argument("--data", required=True, help="a learning.gnn_dataset folder (states labelled with exact C_AP)")
    p.add_argument(
        "--value",
        action="append",
        required=True,
        help=f"{HELP}; a bare PATH is a Q-network or GNN checkpoint (repeatable)",
    )

    def run():
        args = p.parse_args()
        torch.set_num_threads(1)
        out = Path(args.out or f"results/value-rank-{Path(args.data).name}.json")
        cli.check_writable(out)
        r = rank(args.value, args.data, args.domain)
        write_json(out, {**r, "provenance": results_provenance({})})
        for row in r["values"]:
            a = row["all"]
            print(
                f"{row['value']}: Spearman {a['spearman']}, Kendall {a['kendall']}, pairs ordered right "
                f"{a['pair_agreement']:.1%}, slope {a['slope_rl_per_pddl']} RL/PDDL over {a['states']} states"
                + "".join(f" | {k}: Spearman {b.get('spearman')}" for k, b in row["by_kind"].items())
            )
        print(f"wrote {out}")

    cli.run(run)


if __name__ == "__main__":
    main()

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
- the same per kind of state (an augmented dataset's prepared states apart);
- once per dataset, the spread of the states' C_AP (mean, std, range): how much
  preparedness varies among them at all.

C_AP is a one-task cost, V_AP a discounted multi-task value, so the two need not
agree state by state; a value that ranks prepared states below unprepared ones
on a whole kind of states does not know that preparation. A GNN checkpoint
trained on these states is scored on its validation split only, on another
dataset on the states outside its training set (`held_out`).

`--credit ATOM` asks about one preparation, e.g. `--credit "(has-water jar_0)"`: of
the labelled states where ATOM is false, up to `--credit-states` (drawn with
--seed) whose copy with ATOM added the layout can reach (no pair of its atoms
proven mutex, `oracles.labelling.ReachablePairs`), both labelled exactly; per
value, the mean credit it gives the atom, [V_AP(with) - V_AP(without)] times
cost_scale in PDDL units, against the exact one-task saving C_AP(without) -
C_AP(with), and the share of pairs it ranks the prepared copy higher.

`--stream NAME` asks whether conditioning V_AP on a stream's next-task distribution ranks states
better (`planning.world.streams`: a Markov agent that does not beat the i.i.d. one, why?). Per
context of the stream (a Markov stream: after each task type, and at a reset; a drifting one: each
phase) with its next-task distribution P_c, the exact conditional C_AP(s | c) = Σ_τ P_c(τ)
cost*(s, τ) (the dataset's per-task optimal costs) is ranked against:

- the exact C_AP under the layout's P (the thesis's i.i.d. assumption): how much conditioning
  reorders the states at all, however good the value (Spearman 1: not at all);
- per value, its V_AP with P_c (`set_distribution`, as a search deployed with that estimator
  scores terminal states) and its V_AP with P: conditioning the value is worth it only where the
  conditioned one ranks by C_AP(s | c) better than the unconditioned one.
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
from planning.world.results import file_prefix


def agreement(v: np.ndarray, c_ap: np.ndarray) -> dict:
    """Rank agreement of a value with -C_AP over a set of states (see the module's docstring)."""
    from learning.gnn.bench import pair_agreement

    if len(v) < 3:
        return {"states": int(len(v))}
    if np.ptp(v) == 0 or np.ptp(c_ap) == 0:  # a constant ranks nothing: no correlation is defined (JSON null)
        return {"states": int(len(v)), "spearman": None, "kendall": None, "pair_agreement": None}
    slope = np.polyfit(-c_ap, v, 1)[0]
    return {
        "states": int(len(v)),
        "spearman": round(float(stats.spearmanr(v, -c_ap)[0]), 4),
        "kendall": round(float(stats.kendalltau(v, -c_ap)[0]), 4),
        "pair_agreement": round(pair_agreement(v, -c_ap), 4),
        "slope_rl_per_pddl": round(float(slope), 5),
    }


def spread(c_ap: np.ndarray) -> dict:
    """How much the states' exact C_AP varies (PDDL units, finite labels): what any value could tell apart,
    and so what a search that prepares could gain per next task at most."""
    c = c_ap[np.isfinite(c_ap)]
    return {k: round(float(f(c)), 1) for k, f in (("mean", np.mean), ("std", np.std), ("min", np.min), ("max", np.max))}


def held_out(cfg: dict, data: str, states: list, model) -> tuple[np.ndarray, str]:
    """Which of a dataset's states a model trained on the dataset `cfg["data"]` (a learning.gnn_train config) did
    not learn from, and how they were chosen: its validation split where `data` is that dataset; else every state
    outside that dataset (another dataset made alike holds many of the same states); every state, said so, where
    that dataset is not at hand or not recorded."""
    from learning.gnn.dataset import read_meta
    from learning.gnn.training import split

    if not cfg.get("data"):
        return np.ones(len(states), dtype=bool), "every state: the model records no training set"
    trained = Path(cfg["data"])
    if trained.resolve() == Path(data).resolve():
        _, val = split(len(states), int(cfg.get("seed", 0)), float(cfg.get("val_fraction", 0.2)))
        only = np.zeros(len(states), dtype=bool)
        only[val] = True
        return only, "the validation split of its own training run"
    if not (trained / "meta.json").is_file():
        return np.ones(len(states), dtype=bool), f"every state: its training set ({trained}) is not here to leave out"
    seen = {model.state_from_atoms(a) for a in read_meta(trained).get("atoms", [])}
    unseen = np.array([s not in seen for s in states], dtype=bool)
    return unseen, f"the {int(unseen.sum())} states not in its training set ({trained})"


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
        "c_ap": spread(labels),
        "values": [],
    }
    for value in values:
        name = str(value) if isinstance(value, (str, Path)) else type(value).__name__
        if isinstance(value, (str, Path)):
            value = load_value(str(value), model)
        keep = np.isfinite(labels)
        row = {"value": name, "kind": type(value).__name__, "gamma": value.gamma}
        payload = getattr(value, "payload", None)
        if payload is not None:  # a model trained on labelled states is scored on states it did not learn
            unseen, row["scored_on"] = held_out(payload.get("config", {}), data, states, model)
            keep &= unseen
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


def credit(values: list, data: str, domain: str, atom: str, n: int = 150, seed: int = 0) -> dict:
    """What each value credits one atom with (the module's `--credit`), against the exact one-task saving."""
    from learning.gnn.dataset import read_meta
    from oracles.labelling import Labeller, ReachablePairs

    meta = read_meta(data)
    model = compile_domain(domain, meta["layout"])
    key = " ".join(atom.split())
    if not key.startswith("("):
        key = f"({key})"
    bit = model.state_from_atoms([key])  # a one-line error if the layout has no such fluent atom
    mutex = ReachablePairs(model)
    pairs = []
    for atoms in meta["atoms"]:
        s = model.state_from_atoms(atoms)
        if not s & bit:
            prepared = model.state_from_atoms([*atoms, key])  # derived atoms recomputed
            if not mutex.violated(prepared):
                pairs.append((s, prepared))
    rng = np.random.default_rng(seed)
    pairs = [pairs[i] for i in sorted(rng.choice(len(pairs), size=min(n, len(pairs)), replace=False))]
    if not pairs:
        raise DomainError("--credit", f"no labelled state of {data} can have {key} added")
    labeller = Labeller(model)
    saving = np.array([labeller.label(a).c_ap - labeller.label(b).c_ap for a, b in pairs])
    out = {
        "atom": key,
        "pairs": len(pairs),
        "seed": seed,
        "exact_saving": {"mean": round(float(saving.mean()), 2), "median": round(float(np.median(saving)), 2)},
        "values": [],
    }
    for value in values:
        name = str(value) if isinstance(value, (str, Path)) else type(value).__name__
        if isinstance(value, (str, Path)):
            value = load_value(str(value), model)
        without = np.asarray(value.v_ap([a for a, _ in pairs]), dtype=float)
        given = (np.asarray(value.v_ap([b for _, b in pairs]), dtype=float) - without) * model.cost_scale
        out["values"].append(
            {
                "value": name,
                "credit_mean": round(float(given.mean()), 2),
                "credit_median": round(float(np.median(given)), 2),
                "ranks_prepared_higher": round(float(np.mean(given > 0)), 4),
            }
        )
    return out


def dataset_costs(data) -> np.ndarray:
    """(states, tasks) the exact optimal cost of each task instance from each labelled state of a
    learning.gnn_dataset folder (its graphs' `costs`), inf where the task has no plan."""
    from learning.gnn.dataset import load_dataset

    ds = load_dataset(data)
    costs = np.stack([ds[i].costs[0].numpy() for i in range(len(ds))]).astype(float)
    costs[costs < 0] = np.inf
    return costs


def stream_contexts(stream) -> list[tuple[str, np.ndarray]]:
    """(name, (instances,) next-task distribution) of each context in which a stream's P(next task) differs:
    a Markov stream's start and its row after each type, a drifting stream's phases."""
    if stream.kind == "markov":
        rows = [("at a reset", stream.probabilities(None))]
        for k, ty in enumerate(stream.types):
            first = next(t for t in stream.model.tasks if stream.type_of[t.index] == k)
            rows.append((f"after {ty}", stream.probabilities(first)))
        return rows
    if stream.kind == "drift":
        return [(f"from task {f}", stream.probabilities(None, f)) for f, _ in stream.phases]
    raise DomainError(
        "--stream", f"{stream.name} is the i.i.d. stream: its one distribution is P (rank without --stream)"
    )


def conditional(values: list, data: str, domain: str, stream_name: str) -> dict:
    """The `--stream` figures of the module's docstring, per context of the stream and per value."""
    from learning.gnn.dataset import read_meta
    from learning.gnn.model import check_made_for
    from planning.world.streams import stream as stream_of

    meta = read_meta(data)
    model = compile_domain(domain, meta["layout"])
    check_made_for(Path(data) / "meta.json", meta, model, "dataset")
    stream = stream_of(model, stream_name)
    contexts = stream_contexts(stream)
    costs = dataset_costs(data)
    if costs.shape != (len(meta["atoms"]), len(model.tasks)):
        raise DomainError(data, f"its graphs hold {costs.shape} task costs, not one per state and task of the layout")
    p = np.asarray(model.tasks.probabilities, dtype=float)
    p /= p.sum()
    keep = np.isfinite(costs[:, p > 0]).all(1)  # states from which every task of the support has a plan
    costs = np.where(np.isfinite(costs), costs, 0.0)[keep]
    states = [model.state_from_atoms(a) for a, k in zip(meta["atoms"], keep) if k]
    c_p = np.round(costs @ p, 9)  # sums of integer costs: equal ones stay ties, not round-off apart
    loaded = []
    for value in values:
        name = str(value) if isinstance(value, (str, Path)) else type(value).__name__
        loaded.append((name, load_value(str(value), model) if isinstance(value, (str, Path)) else value))
    unconditioned = []
    for _, value in loaded:
        if hasattr(value, "set_distribution"):
            value.set_distribution(None)
        unconditioned.append(np.asarray(value.v_ap(states), dtype=float))
    rows = []
    for context, q in contexts:
        c_q = np.round(costs @ q, 9)
        row = {
            "context": context,
            "next_types": {ty: round(float(q[stream.type_of == k].sum()), 4) for k, ty in enumerate(stream.types)},
            "mean_c_ap": round(float(c_q.mean()), 2),
            "exact_under_p": agreement(-c_p, c_q),
            "values": [],
        }
        for (name, value), v_p in zip(loaded, unconditioned):
            entry = {"value": name, "unconditioned": agreement(v_p, c_q), "conditioned": None}
            if hasattr(value, "set_distribution"):
                value.set_distribution(q)
                entry["conditioned"] = agreement(np.asarray(value.v_ap(states), dtype=float), c_q)
                value.set_distribution(None)
            row["values"].append(entry)
        rows.append(row)
    return {
        "stream": stream.name,
        "kind": stream.kind,
        "states": len(states),
        "dataset": meta.get("config"),
        "contexts": rows,
    }


def _data_domain(data: str) -> str | None:
    """The PDDL domain a dataset folder was labelled in (a one-line error for a folder that is no dataset)."""
    from learning.gnn.dataset import read_meta

    return read_meta(data).get("domain")


def main() -> None:
    p = cli.parser(
        __doc__.splitlines()[0],
        layout=False,
        seed=True,
        helps={
            "out": "results JSON (default: results/value-rank-<dataset folder name>.json, after the domain's name "
            "and a dash for a domain other than the restaurant)",
            "seed": "which states --credit draws (default: %(default)s)",
        },
    )
    p.add_argument("--data", required=True, help="a learning.gnn_dataset folder (states labelled with exact C_AP)")
    p.add_argument(
        "--value",
        action="append",
        required=True,
        help=f"{HELP}; a bare PATH is a Q-network or GNN checkpoint (repeatable)",
    )

    p.add_argument("--credit", default=None, help="an atom: what each value credits it with (see the module)")
    p.add_argument("--credit-states", type=int, default=150, help="pairs of states for --credit (default: 150)")
    p.add_argument(
        "--stream", default=None, help="a stream of domain.toml: rank by its conditional C_AP (see the module)"
    )

    def run():
        args = p.parse_args()
        torch.set_num_threads(1)
        out = Path(args.out or f"results/{file_prefix(_data_domain(args.data))}value-rank-{Path(args.data).name}.json")
        cli.check_writable(out)
        r = rank(args.value, args.data, args.domain)
        for row in r["values"]:
            a = row["all"]
            print(
                f"{row['value']}: Spearman {a['spearman']}, Kendall {a['kendall']}, pairs ordered right "
                f"{a['pair_agreement']:.1%}, slope {a['slope_rl_per_pddl']} RL/PDDL over {a['states']} states"
                + "".join(f" | {k}: Spearman {b.get('spearman')}" for k, b in row["by_kind"].items())
            )
        if args.credit is not None:
            c = r["credit"] = credit(args.value, args.data, args.domain, args.credit, args.credit_states, args.seed)
            e = c["exact_saving"]
            print(
                f"{c['atom']} over {c['pairs']} pairs of states: exact one-task saving mean {e['mean']:.1f}, "
                f"median {e['median']:.1f} PDDL units"
            )
            for row in c["values"]:
                print(
                    f"  {row['value']}: credit mean {row['credit_mean']:.1f}, median {row['credit_median']:.1f}; "
                    f"ranks the prepared state higher on {row['ranks_prepared_higher']:.0%}"
                )
        if args.stream is not None:
            c = r["conditional"] = conditional(args.value, args.data, args.domain, args.stream)
            print(
                f"stream {c['stream']} over {c['states']} states, Spearman with the context's exact C_AP: "
                "the exact C_AP under P | per value, V_AP with P / V_AP with the context's P"
            )
            for row in c["contexts"]:
                print(
                    f"  {row['context']}: exact under P {row['exact_under_p']['spearman']}"
                    + "".join(
                        f" | {e['value']}: {e['unconditioned']['spearman']} / "
                        f"{'n/a' if e['conditioned'] is None else e['conditioned']['spearman']}"
                        for e in row["values"]
                    )
                )
        write_json(out, {**r, "provenance": results_provenance({})})
        print(f"wrote {out}")

    cli.run(run)


if __name__ == "__main__":
    main()

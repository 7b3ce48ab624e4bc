"""The supervised dataset of the one-task GNN baseline (thesis §5.2.2 items 3-4, Appendix A.1).

The command (the library: `learning.gnn.dataset`):

    python -m learning.gnn_dataset --layout three-room [--augmented] --n-states 2000 [--out DIR] [--force]
"""

from __future__ import annotations

import time

from learning.gnn.dataset import DatasetConfig, build, default_out
from planning import cli
from planning.errors import DomainError


def main() -> None:
    p = cli.parser(__doc__.splitlines()[0], seed=True, out="folder", progress=True)
    p.add_argument("--augmented", action="store_true", help="add counterfactual prepared states")
    p.add_argument("--n-states", type=int, default=2000, help="faithful states (default: %(default)s)")
    p.add_argument("--n-prepared", type=int, default=None, help="prepared states (default: 3 x n-states)")
    p.add_argument(
        "--workers",
        type=int,
        default=2,
        help="processes collecting prepared states and labelling (default: %(default)s)",
    )
    p.add_argument(
        "--heuristic",
        default="pdb",
        help="labelling search heuristic: pdb, lmcut, lmcut-pc, hmax, blind (default: %(default)s)",
    )
    p.add_argument(
        "--reuse-labels",
        action="append",
        default=[],
        metavar="DIR",
        help="take the labels another gnn_dataset folder already computed (repeatable)",
    )
    p.add_argument(
        "--force",
        action="store_true",
        help="replace a finished dataset in --out made with other settings or domain content",
    )
    args = p.parse_args()
    if args.n_states < 1:
        raise DomainError("--n-states", f"{args.n_states} is not a positive number of states")
    from planning.domain.compiler import compile_domain

    model = compile_domain(args.domain, args.layout)
    layout = model.layout
    args.out = args.out or str(default_out(model, args.augmented))
    cfg = DatasetConfig(
        layout=layout,
        domain=args.domain,
        n_states=args.n_states,
        augmented=args.augmented,
        n_prepared=args.n_prepared,
        seed=args.seed,
        workers=args.workers,
        heuristic=args.heuristic,
    )
    from planning.heuristics import names

    if cfg.heuristic not in names("multi-goal"):
        raise DomainError("--heuristic", f"'{cfg.heuristic}' is not one of {', '.join(names('multi-goal'))}")
    t0 = time.perf_counter()
    meta = build(cfg, args.out, progress=not args.no_progress, reuse=args.reuse_labels, force=args.force)
    n = len(meta["kinds"])
    print(
        f"{n} states ({meta['kinds'].count('faithful')} faithful, {meta['kinds'].count('prepared')} prepared) "
        f"in {time.perf_counter() - t0:.1f}s: faithful states {meta['seconds_faithful_states']}s, prepared "
        f"states and labels {meta['seconds_collecting_and_labelling']}s ({meta['label_cpu_seconds']} CPU s "
        f"labelling); wrote {args.out}"
    )


if __name__ == "__main__":
    cli.run(main)

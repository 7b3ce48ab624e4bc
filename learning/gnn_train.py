"""Training the one-task GNN estimator of C_AP (thesis Appendix A.1).

The command (the library: `learning.gnn.training`):

    python -m learning.gnn_train --data runs/gnn/three-room-faithful --seed 0 [--epochs 40] --out DIR
"""

from __future__ import annotations

from pathlib import Path

from learning.gnn.training import TrainConfig, train
from planning import cli
from planning.errors import DomainError


def main() -> None:
    p = cli.parser(__doc__.splitlines()[0], seed=True, out="folder", progress=True)
    p.add_argument("--data", required=True, help="a learning.gnn_dataset folder")
    p.add_argument(
        "--epochs", type=int, default=40, help="epochs (default: %(default)s; the thesis: 40 faithful, 12 augmented)"
    )
    p.add_argument(
        "--edge-features",
        action="store_true",
        help="let the layers read the edges' relation one-hot (the thesis's take no edge features)",
    )
    args = p.parse_args()
    if not args.out:
        raise DomainError("--out", "an output folder is required")
    if args.epochs < 1:
        raise DomainError("--epochs", f"{args.epochs} is not a positive number of epochs")
    if args.layout is not None:  # optional: checks the dataset is of this domain and layout
        from learning.gnn.dataset import read_meta
        from learning.gnn.model import check_made_for
        from planning.domain.compiler import compile_domain

        model = compile_domain(args.domain, args.layout)
        check_made_for(Path(args.data) / "meta.json", read_meta(args.data), model, "dataset")
    cfg = TrainConfig(data=str(args.data), seed=args.seed, epochs=args.epochs, edge_features=args.edge_features)
    s = train(cfg, args.out, progress=not args.no_progress)
    print(
        f"seed {cfg.seed}: best validation L1 {s['best_val_l1']:.2f} (epoch {s['best_epoch']}), "
        f"final {s['final_val_l1']:.2f}, {s['seconds_per_epoch']} s/epoch, {s['parameters']} parameters, "
        f"{s['n_train']}/{s['n_val']} train/validation; wrote {args.out}"
    )


if __name__ == "__main__":
    cli.run(main)

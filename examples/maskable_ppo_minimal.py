"""MaskablePPO (sb3-contrib) on the minimal grid domain through the Gymnasium environment.

The thesis's §5.1 example: clear C (pick the apple up and put it on A or B), then deliver
the apple to B (probability 0.8) or A (0.2); +10 per task, 1 per step. An agent that
anticipates puts the apple on B. This trains sb3-contrib's MaskablePPO, off the shelf, on
`AnticipatoryMinimal-grid-v0` in both horizons of `learning.gym_env` (anticipatory: the
two-task episode; myopic: each task its own episode), then plays the trained policy on
1,000 fresh episodes, sampling its actions (as our DQN's figure samples a softmax over Q),
and reports the share of the apple's placements on B, beside our DQN's from
results/minimal-example.json.

    pip install -e '.[rl]'
    python examples/maskable_ppo_minimal.py [--steps 40000] [--seed 0] [--out results/maskable-ppo-minimal.json]
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import gymnasium as gym
import torch

import learning.gym_env  # noqa: F401  (registers the environment ids)
from planning import cli

ROOT = Path(__file__).resolve().parents[1]
ENV_ID = "AnticipatoryMinimal-grid-v0"


def placements(model, policy, horizon: str, episodes: int, seed: int, deterministic: bool) -> dict:
    """Where the clear(c) task leaves the apple, over `episodes` fresh worlds played by `policy`."""
    env = gym.make(ENV_ID, horizon=horizon).unwrapped
    on = {c: model.state_from_atoms([f"(at apple {c})"]) for c in ("a", "b")}
    counts = {"a": 0, "b": 0, "other": 0, "abandoned": 0}
    obs, info = env.reset(seed=seed)
    for _ in range(episodes):
        while info["task"] == "clear(c)" and not info["finished"]:
            action, _ = policy.predict(obs, action_masks=env.action_masks(), deterministic=deterministic)
            obs, _, terminated, truncated, info = env.step(int(action))
        f = info["finished"]
        if f and f["task"] == "clear(c)" and f["success"]:
            counts[next((c for c, m in on.items() if env.state & m), "other")] += 1
        else:
            counts["abandoned"] += 1
        # on to the next episode: a fresh world with clear(c) again
        obs, info = env.reset() if horizon == "anticipatory" else _next_clear(env)
    placed = counts["a"] + counts["b"]
    return {"share_B": round(counts["b"] / max(1, placed), 3), **counts}


def _next_clear(env):
    """Myopic horizon: reset() continues the world; skip the delivery task to the next clear(c)."""
    obs, info = env.reset()
    while info["task"] != "clear(c)":
        obs, info = env.reset()
    return obs, info


def train(horizon: str, steps: int, seed: int) -> tuple:
    from sb3_contrib import MaskablePPO

    env = gym.make(ENV_ID, horizon=horizon)
    model = MaskablePPO(
        "MlpPolicy",
        env,
        seed=seed,
        verbose=0,
        n_steps=1024,
        batch_size=128,
        gamma=0.99,
        ent_coef=0.01,
        learning_rate=1e-3,
        device="cpu",
    )
    t0 = time.perf_counter()
    model.learn(total_timesteps=steps, progress_bar=False)
    return model, time.perf_counter() - t0


def main() -> None:
    p = cli.parser(__doc__.splitlines()[0], domain=False, layout=False, seed=True)
    p.add_argument("--steps", type=int, default=40_000, help="environment steps per horizon (default: %(default)s)")
    p.add_argument("--episodes", type=int, default=1000, help="episodes measured (default: %(default)s)")
    p.add_argument("--horizons", default="anticipatory,myopic")
    args = p.parse_args()
    try:
        import sb3_contrib  # noqa: F401
    except ImportError:
        sys.exit("error: sb3-contrib is not installed: pip install -e '.[rl]'")
    torch.set_num_threads(1)
    env_model = gym.make(ENV_ID).unwrapped.model
    dqn_file = ROOT / "results" / "minimal-example.json"
    dqn = json.loads(dqn_file.read_text()) if dqn_file.is_file() else {}
    result = {"env": ENV_ID, "steps": args.steps, "seed": args.seed, "episodes": args.episodes}
    for horizon in args.horizons.split(","):
        policy, seconds = train(horizon, args.steps, args.seed)
        sampled = placements(env_model, policy, horizon, args.episodes, args.seed + 1, deterministic=False)
        greedy = placements(env_model, policy, horizon, args.episodes, args.seed + 1, deterministic=True)
        result[horizon] = {
            "sampled": sampled,
            "greedy": greedy,
            "train_seconds": round(seconds, 1),
            "dqn_share_B": dqn.get(horizon, {}).get("share_B"),
        }
        print(
            f"{horizon:13s} MaskablePPO share of placements on B: {sampled['share_B']:.3f} sampled, "
            f"{greedy['share_B']:.3f} greedy ({args.steps} steps, {seconds:.0f} s); "
            f"our DQN (softmax over Q): {result[horizon]['dqn_share_B']}",
            flush=True,
        )
    if args.out:
        Path(args.out).write_text(json.dumps(result, indent=1) + "\n")
        print(f"wrote {args.out}")


if __name__ == "__main__":
    cli.run(main)

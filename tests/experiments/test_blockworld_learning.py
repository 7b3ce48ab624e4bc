"""The learners on the second real domain, the persistent blockworld (issue 37), with tiny settings: the
Double-DQN of both horizons trained, exported and deployed greedily and guided, the simulator benchmark and
Gymnasium's checker on its environment (the planning tools: test_blockworld_tools.py, the GNN: test_blockworld_gnn.py)."""

import warnings

from tests.blockworld_copy import LAYOUT, played, run


def test_both_values_train_export_and_play_on_the_blockworld(bw):
    work, d = bw
    common = ("--domain", d, "--layout", LAYOUT)
    play = (*common, "--sequences", "0")
    tiny = ("--steps", 80, "--learning-starts", 20, "--demo-tasks", 3, "--eval-every", 80, "--eval-tasks", 2)
    tiny += ("--log-every", 40, "--goal-reward", 30, "--hidden", 16)
    for h in ("myopic", "anticipatory"):
        run(work, "learning.dqn", *common, "--horizon", h, *tiny, "--out", f"runs/dqn-{h}")
        run(
            work,
            "learning.export",
            f"runs/dqn-{h}",
            "--out",
            f"checkpoints/q-{h}.pt",
            "--figures",
            f"results/t-{h}.json",
        )
    run(work, "experiments.evaluate", *play, "--agent", "rl-greedy", "--checkpoint", "checkpoints/q-myopic.pt")
    guided = ("--checkpoint", "checkpoints/q-anticipatory.pt", "--budget", 30, "--beta", 1.5)
    run(work, "experiments.evaluate", *play, "--agent", "rl-guided", *guided)
    played(work, ["rl-greedy", "rl-guided"])
    sim = ("--states", 20, "--seconds", 0.05, "--out", "results/sim.json")
    run(work, "planning.external.simulator_bench", *common, *sim)


def test_the_gymnasium_checker_passes_on_the_blockworld():
    import gymnasium as gym
    from gymnasium.utils.env_checker import check_env

    import learning.gym_env  # noqa: F401  (registers the bundled domains' ids)

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(gym.make(f"AnticipatoryBlockworld-{LAYOUT}-v0").unwrapped)

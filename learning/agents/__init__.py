"""The agents that deploy a learned value: rl-greedy (greedy), rl-guided and gnn-guided (guided), gnn-native, and the Bellman–Novelty search benchmark (bench_bn)."""

"""Learned values: observation and factored-action encodings, the Q-network and its trainer, the GNN baseline."""

"""The factored Q-network of the thesis (§4.1): network, inference engines, Bellman targets, checkpoints, replay, optimizer, trainer and its benchmark."""

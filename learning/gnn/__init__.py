"""The one-task GNN baseline (thesis Appendix A.1, after Talukder et al. 2024): state graphs, model, candidates, dataset, training, value and benchmark."""

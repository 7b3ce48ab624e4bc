"""Planning references: the myopic, clairvoyant-K and labelling oracles."""

"""Learning in robotics: datasets, MDPs, policy search, movement primitives."""

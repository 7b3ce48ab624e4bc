"""PDDL domains compiled into a fast grounded simulator, and the searches that use it."""

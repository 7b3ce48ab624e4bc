"""Evaluations, demonstrations and the reproduction of the thesis's tables."""

"""Fitting simulation parameters to recordings: the paper's pose error (eq. 1-4) and its optimisers."""

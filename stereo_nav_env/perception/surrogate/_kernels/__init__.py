"""Compiled loops of the surrogate (private: nothing outside the surrogate imports them).

Each loop has a readable reference beside its public function, compared by a test.
"""

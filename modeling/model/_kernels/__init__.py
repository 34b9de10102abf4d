"""Compiled loops of :mod:`modeling.model` (private: nothing outside :mod:`modeling.model` imports
them).

Each module holds the Numba loops of one public module. Every loop takes and returns small named
structures and has a readable reference (plain NumPy or Python, the paper's formulation) beside
its public function; a test compares the two on seeded random inputs. Setting
``NUMBA_DISABLE_JIT=1`` runs every loop as plain Python.
"""

"""pyrt shading kernels: pure NumPy functions of arrays.

Nothing in this package imports ``pyrt`` or ``embreex``, reads files (other than what a texture
needs), or keeps module state. Every kernel is a free function of ``(N, 3)`` / ``(N,)`` arrays
that can be tested alone against a formula.
"""

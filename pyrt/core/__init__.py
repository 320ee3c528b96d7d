"""The bottom layer: errors, parameter checks, the camera, the sampler, image I/O.

Imports only :mod:`pyrt.shaders` and third-party libraries (checked by tests/test_architecture.py).
"""

"""Applications over the public API: the command line, the asset previewer, the shadow-acne suite."""

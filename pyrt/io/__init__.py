"""Readers and writers: images (EXR, PNG) and scene files."""

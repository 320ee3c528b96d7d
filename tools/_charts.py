"""What the tools share: matplotlib behind the 'charts' extra."""


def pyplot():
    """``matplotlib.pyplot`` on the Agg backend; a clear message if the 'charts' extra is not installed."""
    try:
        import matplotlib
    except ImportError:
        raise SystemExit("this tool needs the 'charts' extra: pip install 'pyrt-embree[charts]'") from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt
